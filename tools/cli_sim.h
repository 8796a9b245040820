// The plan -> motion -> simulation pipeline shared by `imubench simulate` and `imubench run`.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "calib/bench_truth.h"
#include "calib/model/motion.h"
#include "calib/noise.h"
#include "calib/simulator.h"
#include "io/recording.h"
#include "plans/plan.h"
#include "tools/cli_common.h"

namespace imubench::tools {

struct SimRequest {
  std::string plan_path;
  calib::BenchTruth truth;
  SiteOptions site;
  double imu_rate_hz = 200.0;    // typical navigation-grade IMU output rate
  double table_rate_hz = 100.0;  // typical encoder logging rate
  std::uint64_t seed = 1;
  calib::NoiseModel noise;  // default: none
  // Temperature-dependent coefficients (--thermal-truth, imubench-thermal/1): replace
  // truth.sensors at the plan's IMU temperature (calib/simulator.h).
  std::optional<calib::model::ThermalCoefficients> thermal;
};

struct SimOutcome {
  plans::Plan plan;
  calib::Motion motion;
  calib::Simulation sim;
  nav::Site site;
};

// Loads, validates and expands the plan and simulates it. On any problem prints it on stderr
// (plan diagnostics one per line) and throws CommandFailed.
SimOutcome simulatePlanOrFail(const SimRequest& request);

// The simulation as an imubench-csv/1 recording.
io::Recording recordingOf(const SimOutcome& outcome, const SimRequest& request);

// Writes it (throws CommandFailed with the file error).
void writeRecordingOrFail(const std::string& dir, const io::Recording& rec);

}  // namespace imubench::tools
