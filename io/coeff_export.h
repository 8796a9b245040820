// Coefficients out to the tools people fly with (`imubench export-coeffs`, docs/export.md):
// Kalibr / OpenVINS IMU chain YAML (kalibr_imu_chain.yaml: noise densities and random walks in
// Kalibr's continuous-time convention, scale-misalignment intrinsics), PX4 parameters
// (CAL_ACC0_*, CAL_GYRO0_*, thermal TC_A0_* / TC_G0_*), ArduPilot parameters (INS_ACCOFFS,
// INS_ACCSCAL, INS_GYROFFS, INS_TCAL1_*), and a plain CSV. Each target's own compensation
// formula is written in the file's header comment; every term the target cannot carry is
// named with the residual error it leaves (`dropped`). Pure text out: the caller writes it.
//
// imubench's sensor equation (interchange.md): reading = diag(s) (M u - b), so the
// compensation is u = M^-1 diag(s)^-1 reading + M^-1 b.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"
#include "io/thermal_file.h"

namespace imubench::io {

enum class ExportTarget { kKalibr, kOpenVins, kPx4, kArduPilot, kCsv };
bool exportTargetFromName(const std::string& name, ExportTarget* target);

// Continuous-time noise of one triad per axis (Kalibr's convention): white-noise density
// (accel m/s^2/sqrt(Hz), gyro rad/s/sqrt(Hz)) and bias random walk (m/s^3/sqrt(Hz),
// rad/s^2/sqrt(Hz)); random_walk_bound: the holds were too short to see the +1/2 slope and
// the random walk is the upper bound the longest averaging time allows.
struct TriadNoise {
  std::array<double, 3> density{};
  std::array<double, 3> random_walk{};
  bool random_walk_bound = false;
};
struct NoiseEstimate {
  TriadNoise accel, gyro;
  double static_s = 0.0;  // total static time the Allan deviation pooled
  double rate_hz = 0.0;   // the recording's IMU rate (Kalibr's update_rate)
  std::string source;     // "Allan deviation of the static holds of DIR"
};

struct ExportInput {
  calib::SensorModel sensors;          // constant coefficients (the coefficient file)
  std::optional<Mat3> gyro_g_sens;     // extra.gyro_g_sensitivity.G, when present
  std::optional<ThermalFile> thermal;  // --thermal comp.json
  std::optional<NoiseEstimate> noise;  // --recording DIR
  std::string source;                  // the coefficient file's path (for the header)
};

struct ExportResult {
  Status status = Status::Error("not exported");
  std::string text;                  // the file's content
  std::vector<std::string> dropped;  // each term the target cannot carry, with its residual
};

ExportResult exportCoefficients(ExportTarget target, const ExportInput& input);

}  // namespace imubench::io
