// The recordings the calibration benches time: a bundled plan (plans/library/NAME.toml)
// simulated at 2 kHz IMU / 100 Hz table with navigation-grade noise and table errors, the same
// truth for every bench so their times compare.
#pragma once

#include <cstdio>
#include <string>

#include "calib/simulator.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::bench {

struct PlanFixture {
  calib::Simulation sim;
  double duration_s = 0.0;
  bool ok = false;
};

// IMUBENCH_PLAN_DIR/name.toml simulated; ok false (and a message on stderr) when the plan does
// not load, validate, expand or simulate.
inline PlanFixture simulatePlan(const char* name) {
  using namespace imubench::calib;
  PlanFixture out;
  const std::string path = std::string(IMUBENCH_PLAN_DIR) + "/" + name + ".toml";
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  if (!plan || !plans::validatePlan(*plan, diag)) {
    std::fprintf(stderr, "plan %s: %s\n", path.c_str(), diag.str().c_str());
    return out;
  }
  const plans::ExpandResult e = plans::expand(*plan);
  if (!e.status.ok) return out;
  SimulatorInput si;
  si.world.site.latitude_rad = 58.0 * kDegToRad;
  si.world.site.height_m = 100.0;
  si.world.noise.gyro.white = 0.002 * kDegToRad / 60.0;
  si.world.noise.accel.white = 20.0 * 9.80665e-6;
  BenchTruth& t = si.world.truth;
  t.sensors.accel.scale = Vec3(1.0002, 0.9997, 1.0001);
  t.sensors.gyro.scale = Vec3(0.9998, 1.0003, 1.0001);
  t.sensors.accel.bias = Vec3(50, -50, 50) * 9.80665e-6;
  t.sensors.gyro.bias = Vec3(-0.01, 0.01, 0.01) * kDegPerHourToRadPerSec;
  t.sensors.accel.mis = {1e-4, -2e-4, 3e-4, -1e-4, 2e-4, -3e-4};
  t.sensors.gyro.mis = {-2e-4, 1e-4, -3e-4, 2e-4, -1e-4, 3e-4};
  t.table.base_tilt = Vec2(40, -25) * kArcsecToRad;
  t.table.mounting = Vec2(-30, 50) * kArcsecToRad;
  t.table.nonorthogonality.inner_y = 35 * kArcsecToRad;
  si.motion = e.motion;
  SimOptions so;
  so.imu_rate_hz = 2000.0;
  so.table_rate_hz = 100.0;
  out.sim = simulate(si, so);
  out.duration_s = e.motion.duration;
  out.ok = out.sim.status.ok;
  return out;
}

}  // namespace imubench::bench
