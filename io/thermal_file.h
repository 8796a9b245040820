// Thermal compensation files (interchange.md "Thermal compensation file", imubench-thermal/1):
//   {"format": "imubench-thermal/1", "imu": {"serial": ..}, "t_ref_c": x, "range_c": [lo, hi],
//    "accel": {"scale": [P, P, P], "bias": [P, P, P], "misalignment": {"xy": P, ...}},
//    "gyro": {same keys}}
//   P = {"poly": [c0, .., cn], "dTdt": h, "sigma": {"poly": [..], "dTdt": x}}
// "dTdt" is written only for a coefficient with a hysteresis term; "sigma" only when a sigma
// is known. The CSV form has one row per coefficient:
//   triad,coefficient,axis,c0,c1,c2,c3,c4,dTdt,tmin,tmax   (unused orders empty).
// The same file is the simulator's thermal truth (`imubench simulate --thermal-truth`).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "base/status.h"
#include "calib/model/thermal_coefficients.h"

namespace imubench::io {

inline constexpr const char* kThermalFormat = "imubench-thermal/1";

struct ThermalFile {
  std::string imu_serial;  // the IMU the model belongs to ("" when unknown, e.g. a truth)
  calib::model::ThermalCoefficients coefficients;
};

nlohmann::json toJson(const ThermalFile& file);
// false with *why naming the JSON path at fault ("accel.bias[1].poly: ...").
bool fromJson(const nlohmann::json& j, ThermalFile* file, std::string* why);

// status "path: why" / "path:line: JSON syntax error"; the file in value, valid only when ok().
using ThermalFileResult = Result<ThermalFile>;

ThermalFileResult readThermalFile(const std::string& path);
Status writeThermalFile(const std::string& path, const ThermalFile& file);
Status writeThermalCsv(const std::string& path, const ThermalFile& file);

}  // namespace imubench::io
