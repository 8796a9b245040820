// The coefficient / truth JSON of interchange.md, in and out. Values only: no file I/O here
// (daemon/ and tools/ read and write the files).
//
//   {"accel": {"scale": [3], "bias": [3], "misalignment": {"xy","xz","yx","yz","zx","zy"}},
//    "gyro":  {same},
//    "table": {"base_tilt": [tx, ty], "nonorthogonality": [nu_y] (two-axis) or
//              [nu1_x, nu1_y, nu2_y] (three-axis), "mounting": [mx, my],
//              "encoder_zero": [o0, i0] (two-axis) or [o0, m0, i0] (three-axis)},
//    "extra": {effect id: {param: number | [3] | [[3],[3],[3]]}}}
// Units SI. Missing groups/keys keep their defaults (scale 1, everything else 0; a missing
// "table" is a perfect table); unknown keys, effect ids or parameters are errors.
//
// Estimates (calibration results) use the same layout; each group object ("accel", "gyro",
// "table", "extra".<id>) may carry two sibling keys:
//   "sigma":      {key: same shape as the value}   (null entries: no uncertainty)
//   "observable": {key: false | same shape of booleans}  (only keys with something unobservable)
// e.g. "accel": {"bias": [..], "sigma": {"bias": [..]}, "observable": {"misalignment": {"xz":
// false}}} CoefficientReport writes and reads that; both the truth files and the calibrators'
// results go through the same code path.
//
// Flat names: every scalar coefficient has a name "accel.scale.x", "accel.bias.z",
// "gyro.misalignment.xy", "table.base_tilt.x", "table.nonorthogonality.inner_y",
// "table.nonorthogonality.middle_x", "table.mounting.y", "table.encoder_zero.outer",
// "extra.lever_arm.r_m.x", ... used by observability reports and fitting code.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/effects.h"
#include "calib/model/motion.h"
#include "calib/sensor_model.h"
#include "calib/table_model.h"

namespace imubench::calib {

struct BenchTruth {
  SensorModel sensors;
  TableErrors table;
  // Which chain `table` belongs to: sets the lengths of "nonorthogonality" and
  // "encoder_zero" in JSON. fromJson infers it from those lengths (two-axis if absent).
  TableKind table_kind = TableKind::kTwoAxis;
  EffectSet extra;
};

nlohmann::json toJson(const BenchTruth& truth);
// Parses a truth/coefficient object. On error returns false and sets *why to a message that
// names the JSON path, e.g. "accel.misalignment.xy: expected a number". "sigma" and
// "observable" keys are accepted and ignored here (see CoefficientReport).
bool fromJson(const nlohmann::json& j, BenchTruth* truth, std::string* why);

// ---- Flat named view --------------------------------------------------------------------

// All scalar coefficient names of a truth in canonical order: accel (scale xyz, bias xyz,
// misalignment xy..zy), gyro (same), table (base_tilt xy, nonorthogonality per kind, mounting
// xy, encoder_zero per kind), then extra effects in kAllEffects order (enabled ones only).
std::vector<std::string> flatNames(const BenchTruth& truth);
std::vector<double> flatValues(const BenchTruth& truth);  // same order as flatNames
// The table parameters of a table kind by flat name, in flatNames' order ("table.base_tilt.x",
// ..., the encoder zeros last).
std::vector<std::string> tableFlatNames(TableKind kind);
// Sets one scalar by flat name; false (why set) on an unknown name. An "extra.<id>.*" name
// enables that effect.
bool setFlatValue(BenchTruth* truth, const std::string& name, double value, std::string* why);
std::optional<double> flatValue(const BenchTruth& truth, const std::string& name);

// ---- Estimates with uncertainty ---------------------------------------------------------

struct Uncertainty {
  std::optional<double> sigma;  // 1-sigma, same unit as the value
  bool observable = true;       // false: the plan/method cannot see it (value is fixed)
};

struct CoefficientReport {
  BenchTruth values;
  std::map<std::string, Uncertainty> uncertainty;  // by flat name; absent = no information

  void setSigma(const std::string& flat_name, double sigma) {
    uncertainty[flat_name].sigma = sigma;
  }
  void setUnobservable(const std::string& flat_name) { uncertainty[flat_name].observable = false; }
};

nlohmann::json toJson(const CoefficientReport& report);
bool fromJson(const nlohmann::json& j, CoefficientReport* report, std::string* why);

}  // namespace imubench::calib
