// Test fixtures shared by the simulator tests: an ideal bench at the reference site, a
// two-axis motion of one phase per axis, and a simulation that must succeed.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "calib/simulator.h"

namespace imubench::calib::testing {

inline constexpr double kLat = 55.75 * kDegToRad;

// The reference site, no sensor or table errors.
inline BenchWorld idealWorld() {
  BenchWorld w;
  w.site.latitude_rad = kLat;
  w.site.height_m = 150.0;
  return w;
}

// Two-axis motion: each axis holds still, or turns at a constant rate from t = 0.
inline Motion twoAxis(double duration, AxisPhase outer, AxisPhase inner) {
  Motion m;
  m.kind = TableKind::kTwoAxis;
  m.axes.resize(2);
  m.axes[0].append(outer);
  m.axes[1].append(inner);
  m.duration = duration;
  return m;
}

// The delay tests' motion (3 s): the outer axis turns at +45 deg/s from 1 s, the inner at
// -45 deg/s from 0.5 s, both `later_s` later (a delayed IMU on the motion sees what an
// undelayed one sees on it delayed).
inline Motion delayTestMotion(double later_s = 0.0) {
  const double w = 45.0 * kDegToRad;
  return twoAxis(3.0, {1.0 + later_s, 0.0, w, 0.0}, {0.5 + later_s, 0.0, -w, 0.0});
}

// The simulation at `rate` Hz with noise seed `seed`; a failure fails the test.
inline Simulation simulateOk(const BenchWorld& w, const Motion& m, double rate,
                             std::uint64_t seed) {
  SimOptions o;
  o.imu_rate_hz = rate;
  o.seed = seed;
  const Simulation s = simulate({w, m}, o);
  EXPECT_TRUE(s.status.ok) << s.status.message;
  return s;
}

// The largest difference of recording a from references over the samples: per sample
// |dvel_a - dvel_v| + |dtheta_a - dtheta_w| (w nullptr: the velocity increments alone).
inline double largestDifference(const Simulation& a, const Simulation& v,
                                const Simulation* w = nullptr) {
  double worst = 0.0;
  for (std::size_t k = 0; k < a.imu.size(); ++k) {
    double d = (a.imu[k].dvel - v.imu[k].dvel).norm();
    if (w) d += (a.imu[k].dtheta - w->imu[k].dtheta).norm();
    worst = std::max(worst, d);
  }
  return worst;
}

}  // namespace imubench::calib::testing
