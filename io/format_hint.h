// What to do with a file given where a recording directory is expected (`imubench calibrate
// FILE`, `explain FILE`, ... without --format): sniffs the first rows and names the matching
// `--format` (imucal's CSV header, imu_tk's "t x y z" text, imu-calib's six columns) or the
// `imubench import-csv` command with the file's own column names. Empty when the path is not
// a readable regular file.
#pragma once

#include <string>

namespace imubench::io {

std::string recordingFileHint(const std::string& path);

}  // namespace imubench::io
