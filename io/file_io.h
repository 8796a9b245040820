// Whole-file reading shared by the io/ readers (recordings, JSON files): one read into a
// string, no iostreams.
#pragma once

#include <string>

#include "io/io_status.h"

namespace imubench::io {

// Reads the whole file into *out. Errors: "path: missing file", "path: cannot open: ...".
IoStatus readWholeFile(const std::string& path, std::string* out);

}  // namespace imubench::io
