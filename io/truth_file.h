// Coefficient / truth JSON files (interchange.md): file I/O around calib/bench_truth.h's
// toJson/fromJson. Errors name the file and, for JSON syntax errors, the line.
#pragma once

#include <string>

#include "base/status.h"
#include "calib/bench_truth.h"

namespace imubench::io {

// The file's content in value, valid only when ok().
using TruthFileResult = Result<calib::BenchTruth>;
using CoefficientFileResult = Result<calib::CoefficientReport>;

// Reads a truth file ("file:line: JSON syntax error ..." or "file: accel.bias: ...").
TruthFileResult readTruthFile(const std::string& path);
// Writes a truth file (pretty-printed, numbers in round-trip precision).
Status writeTruthFile(const std::string& path, const calib::BenchTruth& truth);

// The same for estimates with "sigma" / "observable" (calibration results).
CoefficientFileResult readCoefficientFile(const std::string& path);
Status writeCoefficientFile(const std::string& path, const calib::CoefficientReport& report);

// Low-level helpers shared by the above (and usable for other JSON files of daemon/ and
// tools/): whole-file JSON parse with file:line errors, and an atomic-enough write (temp
// file + rename, so a reader never sees half a file).
Status readJsonFile(const std::string& path, nlohmann::json* out);
Status writeJsonFile(const std::string& path, const nlohmann::json& j);

// Reads a JSON file into a T by fromJson(json, T*, why) (found by argument-dependent lookup):
// the file's error, or "path: why" when fromJson refuses the content.
template <class T>
Result<T> readJsonFileAs(const std::string& path) {
  Result<T> r;
  nlohmann::json j;
  r.status = readJsonFile(path, &j);
  if (!r.status.ok) return r;
  std::string why;
  if (!fromJson(j, &r.value, &why)) {
    r.status = Status::Error(path + ": " + why);
    r.value = T{};
  }
  return r;
}

}  // namespace imubench::io
