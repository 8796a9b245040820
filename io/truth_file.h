// Coefficient / truth JSON files (interchange.md): file I/O around calib/bench_truth.h's
// toJson/fromJson. Errors name the file and, for JSON syntax errors, the line.
#pragma once

#include <string>

#include "calib/bench_truth.h"
#include "io/io_status.h"

namespace imubench::io {

struct TruthFileResult {
  IoStatus status;
  calib::BenchTruth truth;  // valid only when status.ok
};

struct CoefficientFileResult {
  IoStatus status;
  calib::CoefficientReport report;  // valid only when status.ok
};

// Reads a truth file ("file:line: JSON syntax error ..." or "file: accel.bias: ...").
TruthFileResult readTruthFile(const std::string& path);
// Writes a truth file (pretty-printed, numbers in round-trip precision).
IoStatus writeTruthFile(const std::string& path, const calib::BenchTruth& truth);

// The same for estimates with "sigma" / "observable" (calibration results).
CoefficientFileResult readCoefficientFile(const std::string& path);
IoStatus writeCoefficientFile(const std::string& path, const calib::CoefficientReport& report);

// Low-level helpers shared by the above (and usable for other JSON files of daemon/ and
// tools/): whole-file JSON parse with file:line errors, and an atomic-enough write (temp
// file + rename, so a reader never sees half a file).
IoStatus readJsonFile(const std::string& path, nlohmann::json* out);
IoStatus writeJsonFile(const std::string& path, const nlohmann::json& j);

}  // namespace imubench::io
