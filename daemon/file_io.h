// Whole-file reading shared by the daemon's readers (recordings, JSON files): one read into a
// string, no iostreams.
#pragma once

#include <string>

#include "daemon/io_status.h"

namespace imubench::daemon {

// Reads the whole file into *out. Errors: "path: missing file", "path: cannot open: ...".
IoStatus readWholeFile(const std::string& path, std::string* out);

}  // namespace imubench::daemon
