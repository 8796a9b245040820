// Test helper: a bundled plan simulated with concealed effects, then analysed by explain with
// no hint of what was added (baseline calibrated from the same recording).
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "calib/explain/explain.h"
#include "calib/explain/explain_baseline.h"
#include "calib/simulator.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "test_direct_sim.h"
#include "test_indirect_plan_loader.h"

namespace imubench::calib::testing {

struct SimulatedRecording {
  Simulation sim;
  nav::Site site;
  TableGeometry geometry;
};

inline SimulatedRecording simulateWith(const Motion& motion, const EffectSet& effects,
                                       std::uint64_t seed, double imu_rate_hz = 50.0,
                                       double table_rate_hz = 20.0,
                                       const NoiseModel& noise = NoiseModel::navigationGrade()) {
  SimulatorInput si;
  si.world.site = exampleSite();
  si.world.truth.sensors = exampleSensors();
  si.world.truth.table_kind = motion.kind;
  si.world.truth.extra = effects;
  si.world.noise = noise;
  si.motion = motion;
  SimOptions so;
  so.imu_rate_hz = imu_rate_hz;
  so.table_rate_hz = table_rate_hz;
  so.seed = seed;
  SimulatedRecording r;
  r.sim = simulate(si, so);
  EXPECT_TRUE(r.sim.status.ok) << r.sim.status.message;
  r.site = si.world.site;
  r.geometry.kind = motion.kind;
  return r;
}

// The analysis' input with the baseline calibrated from the recording itself (views into rec).
inline ExplainInput simulatedExplainInput(const SimulatedRecording& rec) {
  BaselineInput bin{rec.geometry, rec.site, rec.sim.imu, rec.sim.table, rec.sim.segments};
  const BaselineCalibration base = calibrateBaseline(bin);
  EXPECT_TRUE(base.status.HasResult()) << base.status.message;
  return explainInput(bin, base);
}

// Baseline calibrated from the recording itself, then the analysis.
inline ExplainResult explainSimulated(const SimulatedRecording& rec,
                                      const ExplainOptions& options = {}) {
  return explainRecording(simulatedExplainInput(rec), options);
}

// A plan file validated and expanded (the test fails when it does not).
inline Motion planFileMotion(const std::string& path) {
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  plans::ExpandResult r = plans::expand(*plan);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return r.motion;
}

// The analysis with the sensor coefficients given (a level recording cannot calibrate them).
inline ExplainInput givenBaseline(const SimulatedRecording& rec) {
  ExplainInput in;
  in.geometry = rec.geometry;
  in.site = rec.site;
  in.imu = rec.sim.imu;
  in.table = rec.sim.table;
  in.segments = rec.sim.segments;
  in.baseline.values.sensors = exampleSensors();
  in.baseline.values.table_kind = rec.geometry.kind;
  in.baseline_method = "given";
  in.baseline_from_this_recording = false;
  return in;
}

// The level recording sees the horizontal accelerometer and gyro terms only weakly (one axis
// up): the joint refit wanders along them, beyond the given-coefficient check meant for
// another unit's file. The check is opened for it; the proposal starts from the given values.
inline ExplainOptions levelOptions() {
  ExplainOptions eo;
  eo.given_max_scale = eo.given_max_misalignment = 1.0;
  eo.given_max_accel_bias = eo.given_max_gyro_bias = 1.0;
  return eo;
}

inline std::string summary(const ExplainResult& r) {
  std::string s = "baseline " + r.baseline_method + ", error '" + r.status.message + "'\n";
  for (const ExplainAccepted& a : r.accepted) {
    s += "  accepted " + a.effect + " dBIC " + std::to_string(a.delta_bic) + ":";
    for (std::size_t k = 0; k < a.values.size(); ++k) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), " %s=%.4g+-%.2g", a.flat_names[k].c_str(), a.values[k],
                    a.sigmas[k]);
      s += buf;
    }
    s += "\n";
  }
  for (const ExplainRejected& x : r.rejected)
    s += "  rejected " + x.effect + ": " + x.reason + "\n";
  for (const ExplainUnseparable& u : r.unseparable) s += "  unseparable: " + u.reason + "\n";
  for (const ExplainWindow& w : r.unexplained) {
    s += "  unexplained " + std::string(explainChannelName(w.channel)) + " " +
         std::to_string(w.t0) + ".." + std::to_string(w.t1) + " " + std::to_string(w.sigma) +
         " sigma\n";
  }
  for (int c = 0; c < 6; ++c) {
    s += "  " + std::string(explainChannelName(c)) + " rms " + std::to_string(r.rms_before[c]) +
         " -> " + std::to_string(r.rms_after[c]) + " (noise " + std::to_string(r.noise_rms[c]) +
         ")\n";
  }
  s += "  scale " + std::to_string(r.scale) + " normalised rms " +
       std::to_string(r.baseline_normalised_rms) + " -> " + std::to_string(r.after_normalised_rms) +
       "\n";
  for (const std::string& n : r.notes) s += "  note: " + n + "\n";
  return s;
}

}  // namespace imubench::calib::testing
