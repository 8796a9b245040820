// Test helper: a bundled plan (libraryMotion) simulated on a bench with a given truth, packaged as
// the direct calibrator's input.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "calib/direct_calibration.h"
#include "calib/observability.h"
#include "calib/simulator.h"
#include "test_indirect_plan_loader.h"

namespace imubench::calib::testing {

// Sensor errors of a navigation-grade-like IMU, misalignments of ~ 1e-3 rad.
inline SensorModel exampleSensors() {
  SensorModel s;
  s.accel.scale = Vec3(1.0012, 0.9991, 1.0004);
  s.accel.bias = Vec3(0.012, -0.008, 0.02);
  s.accel.mis = {1.1e-3, -0.7e-3, 0.5e-3, 0.9e-3, -1.2e-3, 0.4e-3};
  s.gyro.scale = Vec3(1.0003, 0.9996, 1.0008);
  s.gyro.bias = Vec3(2e-6, -3e-6, 1.5e-6);
  s.gyro.mis = {0.8e-3, 0.6e-3, -0.9e-3, 0.3e-3, 1.0e-3, -0.5e-3};
  return s;
}

inline nav::Site exampleSite() {
  nav::Site s;
  s.latitude_rad = 58.0 * kDegToRad;  // Perm
  s.height_m = 170.0;
  return s;
}

// The plan analysis of a motion for the navigation-based calibration at exampleSite.
inline PlanObservability indirectPlanAnalysis(const Motion& motion) {
  PlanObservabilityOptions po;
  po.site = exampleSite();
  return analysePlanObservability(motion, CalibrationMethod::kIndirect, po);
}

inline DirectCalibrationInput simulateDirect(const Motion& motion, const SensorModel& sensors,
                                             const TableErrors& table,
                                             const NoiseModel& noise = NoiseModel::none(),
                                             double imu_rate_hz = 50.0, double table_rate_hz = 20.0,
                                             std::uint64_t seed = 1) {
  SimulatorInput si;
  si.world.site = exampleSite();
  si.world.truth.sensors = sensors;
  si.world.truth.table = table;
  si.world.truth.table_kind = motion.kind;
  si.world.noise = noise;
  si.motion = motion;
  SimOptions so;
  so.imu_rate_hz = imu_rate_hz;
  so.table_rate_hz = table_rate_hz;
  so.seed = seed;
  const Simulation sim = simulate(si, so);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;
  DirectCalibrationInput in;
  in.geometry.kind = motion.kind;
  in.site = si.world.site;
  in.imu = sim.imu;
  in.table = sim.table;
  in.segments = sim.segments;
  return in;
}

}  // namespace imubench::calib::testing
