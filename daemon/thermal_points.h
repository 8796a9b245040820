// Issue 16 item 5: one calibration result per temperature point of a thermal run. A kSoak
// segment (a thermal plan's "T-40C/soak", a chamber step) opens a temperature point; the
// segments after it, up to the next kSoak, are its body (the same rule as the runner's
// temperaturePointStart, daemon/plan_runner.h, on the stored segments). Each body is
// calibrated on its own with the direct method (daemon/run_calibration.h calibrateRun) over
// the samples of its time span, and labelled with the IMU's mean temperature there. Pure:
// value types in, value types out (the daemon runs it on its calibration worker).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/table_model.h"
#include "daemon/plan_runner.h"
#include "io/recording.h"

namespace imubench::daemon {

struct PointCalibration {
  std::string label;          // the point's soak segment label, e.g. "T-40C/soak"
  double setpoint_c = 0.0;    // the soak's chamber setpoint
  double t0 = 0.0, t1 = 0.0;  // the body's span (recording time, s)
  int segments = 0;           // body segments
  // Mean IMU temperature over the body's samples; the chamber's measured one when the IMU
  // reports none; the setpoint when neither was recorded (temperature_source says which).
  double temperature_c = 0.0;
  std::string temperature_source;                   // "imu", "chamber" or "setpoint"
  Status status = Status::Error("not calibrated");  // not ok: why not
  nlohmann::json coefficients;  // calib::toJson of the direct calibration, when status.ok
};

// The plan has a temperature point (a kSoak step): its completed run gets point results.
bool hasTemperaturePoints(const std::vector<RunStep>& steps);

// The temperature points of a recording in time order (a body without segments is left out);
// empty when the recording has no kSoak segment (not a thermal run). known_table_errors: the
// bench file's [table] errors (daemon/run_calibration.h calibrateRun).
std::vector<PointCalibration> calibrateTemperaturePoints(
    const io::Recording& rec, const std::optional<calib::TableErrors>& known_table_errors);

// What the store keeps per point (kind "point_coefficients"): label, setpoint, temperature and
// its source, span, and the coefficients (absent when the point failed, with its error).
nlohmann::json pointJson(const PointCalibration& p);

}  // namespace imubench::daemon
