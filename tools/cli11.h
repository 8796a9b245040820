// CLI11 (header-only) for the imubench command line. GCC 12 reports a false
// -Wnull-dereference inside CLI11's inlined string splitting (std::vector<std::string>
// relocation) under -O2; the warning is silenced for CLI11's own code only.
#pragma once

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#pragma GCC diagnostic pop
