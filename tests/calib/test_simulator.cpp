#include <gtest/gtest.h>

#include <cmath>

#include "calib/simulator.h"
#include "tests/calib/sim_fixtures.h"

namespace imubench::calib {
namespace {

using testing::delayTestMotion;
using testing::idealWorld;
using testing::kLat;
using testing::largestDifference;
using testing::twoAxis;

Simulation run(const BenchWorld& w, const Motion& m, double rate = 100.0, std::uint64_t seed = 1) {
  return testing::simulateOk(w, m, rate, seed);
}

TEST(Simulator, StationaryAtZeroAnglesIsEarthRateAndGravityExactly) {
  const BenchWorld w = idealWorld();
  const Simulation s = run(w, twoAxis(2.0, {}, {}));
  ASSERT_EQ(s.imu.size(), 200u);
  const double dt = 0.01;
  const Vec3 w_ie = nav::earthRateL(kLat);  // B = L at zero angles, heading East
  const double g = nav::siteGravity(w.site);
  for (const nav::ImuSample& x : s.imu) {
    EXPECT_LT((x.dtheta - w_ie * dt).norm(), 1e-12 * (w_ie * dt).norm());
    EXPECT_LT((x.dvel - Vec3(0, 0, g * dt)).norm(), 1e-12 * g * dt);
  }
  EXPECT_DOUBLE_EQ(s.imu.back().t, 2.0);
  EXPECT_DOUBLE_EQ(s.imu.front().t, 0.01);
  ASSERT_EQ(s.table.size(), 201u);  // 100 Hz including t = 0
}

TEST(Simulator, ConstantRateGivesTheTotalAngle) {
  // Inner axis (Up at zero outer) at 10 deg/s for 36 s: 360 deg plus the Earth's vertical rate.
  const double rate = 10.0 * kDegToRad;
  const Simulation s = run(idealWorld(), twoAxis(36.0, {}, {0.0, 0.0, rate, 0.0}));
  Vec3 sum = Vec3::Zero();
  for (const auto& x : s.imu) sum += x.dtheta;
  const double expected = 2.0 * kPi + nav::kEarthRate * std::sin(kLat) * 36.0;
  EXPECT_NEAR(sum.z(), expected, 1e-12 * expected);
  // The horizontal Earth rate averages out over a full turn.
  EXPECT_LT(std::abs(sum.x()), 1e-9);
}

TEST(Simulator, AccelerationLimitedTurnWithOffGridPhasesIsExact) {
  // Inner axis: accelerate 0.37 s, coast, decelerate; phase boundaries fall inside samples.
  const double acc = 20.0 * kDegToRad, ta = 0.37, coast = 5.123;
  const double v = acc * ta;
  Motion m;
  m.kind = TableKind::kTwoAxis;
  m.axes.resize(2);
  m.axes[0].append({0.0, 0.0, 0.0, 0.0});
  const double t1 = 0.2055;
  m.axes[1].append({0.0, 0.0, 0.0, 0.0});
  m.axes[1].append({t1, 0.0, 0.0, acc});
  const double a1 = 0.5 * acc * ta * ta;
  m.axes[1].append({t1 + ta, a1, v, 0.0});
  m.axes[1].append({t1 + ta + coast, a1 + v * coast, v, -acc});
  m.axes[1].append({t1 + 2 * ta + coast, 2 * a1 + v * coast, 0.0, 0.0});
  m.duration = 7.0;
  const Simulation s = run(idealWorld(), m);
  Vec3 sum = Vec3::Zero();
  for (const auto& x : s.imu) sum += x.dtheta;
  const double total = 2 * a1 + v * coast + nav::kEarthRate * std::sin(kLat) * 7.0;
  EXPECT_NEAR(sum.z(), total, 1e-13);
}

TEST(Simulator, OuterRotationMatchesAnalyticSpecificForceIntegral) {
  // Outer axis (East) at 30 deg/s: f_B = g (0, sin a, cos a), a = w t. Per sample the
  // increment is g/w (cos a0 - cos a1, sin a1 - sin a0).
  const double w = 30.0 * kDegToRad;
  BenchWorld world = idealWorld();
  const Simulation s = run(world, twoAxis(12.0, {0.0, 0.0, w, 0.0}, {}), 100.0);
  const double g = nav::siteGravity(world.site);
  double worst = 0.0;
  for (const auto& x : s.imu) {
    const double a0 = w * (x.t - 0.01), a1 = w * x.t;
    const double dvy = g / w * (std::cos(a0) - std::cos(a1));
    const double dvz = g / w * (std::sin(a1) - std::sin(a0));
    worst = std::max(worst, std::abs(x.dvel.y() - dvy) + std::abs(x.dvel.z() - dvz));
  }
  EXPECT_LT(worst, 1e-13);
}

Vec3 meanDvel(const Simulation& s) {
  Vec3 m = Vec3::Zero();
  for (const auto& x : s.imu) m += x.dvel;
  return m / static_cast<double>(s.imu.size());
}

TEST(Simulator, LeverArmAddsCentripetalAtConstantRate) {
  const double w = 60.0 * kDegToRad;
  const Motion m = twoAxis(6.0, {}, {0.0, 0.0, w, 0.0});
  BenchWorld with = idealWorld();
  const Vec3 r(0.1, -0.05, 0.02);
  with.truth.extra.lever_arm = LeverArm{r};
  const Simulation a = run(with, m), b = run(idealWorld(), m);
  const Vec3 centripetal = Vec3(0, 0, w).cross(Vec3(0, 0, w).cross(r));
  for (std::size_t k = 0; k < a.imu.size(); ++k) {
    EXPECT_LT((a.imu[k].dvel - b.imu[k].dvel - centripetal * 0.01).norm(), 1e-14);
  }
  EXPECT_LT(((meanDvel(a) - meanDvel(b)) / 0.01 - centripetal).norm(), 1e-12);
}

TEST(Simulator, StaticEffectsAddTheirTerms) {
  const Motion m = twoAxis(1.0, {}, {});
  const Simulation base = run(idealWorld(), m);
  const double g = nav::siteGravity(idealWorld().site), dt = 0.01;

  BenchWorld w = idealWorld();
  GyroGSensitivity gs;
  gs.G(0, 2) = 1e-6;
  w.truth.extra.gyro_g_sensitivity = gs;
  Simulation s = run(w, m);
  EXPECT_NEAR(s.imu[5].dtheta.x() - base.imu[5].dtheta.x(), 1e-6 * g * dt, 1e-18);

  w = idealWorld();
  w.truth.extra.accel_k2 = AccelK2{Vec3(0, 0, 1e-5)};
  s = run(w, m);
  EXPECT_NEAR(s.imu[5].dvel.z() - base.imu[5].dvel.z(), 1e-5 * g * g * dt, 1e-15);

  w = idealWorld();
  Motion hot = m;
  hot.temperature = {{0.0, 30.0}};
  w.truth.extra.thermal_bias = ThermalBias{Vec3(1e-4, 0, 0), Vec3::Zero(), 20.0};
  s = run(w, hot);
  EXPECT_NEAR(s.imu[5].dvel.x() - base.imu[5].dvel.x(), -1e-4 * 10.0 * dt, 1e-16);
  EXPECT_DOUBLE_EQ(s.imu[5].temp_c, 30.0);

  w = idealWorld();
  w.truth.extra.latitude_error = LatitudeError{0.01};
  w.truth.extra.gravity_error = GravityError{1e-3};
  s = run(w, m);
  EXPECT_LT((s.imu[5].dtheta - nav::earthRateL(kLat + 0.01) * dt).norm(), 1e-18);
  nav::Site shifted = idealWorld().site;
  shifted.latitude_rad += 0.01;
  EXPECT_NEAR(s.imu[5].dvel.z(), (nav::siteGravity(shifted) + 1e-3) * dt, 1e-14);
}

TEST(Simulator, ScaleAsymmetryDependsOnRateSign) {
  const double w = 20.0 * kDegToRad, a = 1e-4;
  BenchWorld asym = idealWorld();
  asym.truth.extra.scale_asymmetry = ScaleAsymmetry{Vec3(0, 0, a)};
  for (double sign : {1.0, -1.0}) {
    const Motion m = twoAxis(1.0, {}, {0.0, 0.0, sign * w, 0.0});
    const Simulation s = run(asym, m), b = run(idealWorld(), m);
    const double u = sign * w + nav::kEarthRate * std::sin(kLat);
    EXPECT_NEAR(s.imu[10].dtheta.z() - b.imu[10].dtheta.z(), a * std::abs(u) * 0.01, 1e-15);
  }
}

TEST(Simulator, TimeDelayShiftsThePhysics) {
  // A delayed IMU at stamp t sees what an undelayed one sees at t - tau: equivalently, the
  // undelayed IMU on a motion that happens tau later.
  const double tau = 0.0037;
  BenchWorld delayed = idealWorld();
  delayed.truth.extra.time_delay = TimeDelay{tau};
  const Simulation a = run(delayed, delayTestMotion());
  const Simulation b = run(idealWorld(), delayTestMotion(tau));
  const Simulation c = run(idealWorld(), delayTestMotion());
  EXPECT_LT(largestDifference(a, b, &b), 1e-13);
  EXPECT_GT(largestDifference(a, c), 1e-4);  // and the delay is visible
}

TEST(Simulator, DeterministicPerSeed) {
  BenchWorld w = idealWorld();
  w.noise = NoiseModel::tactical();
  const Motion m = twoAxis(2.0, {}, {0.0, 0.0, 0.3, 0.0});
  const Simulation a = run(w, m, 100.0, 7), b = run(w, m, 100.0, 7), c = run(w, m, 100.0, 8);
  ASSERT_EQ(a.imu.size(), b.imu.size());
  bool differs = false;
  for (std::size_t k = 0; k < a.imu.size(); ++k) {
    EXPECT_EQ(a.imu[k].dtheta, b.imu[k].dtheta);
    EXPECT_EQ(a.imu[k].dvel, b.imu[k].dvel);
    differs = differs || a.imu[k].dtheta != c.imu[k].dtheta;
  }
  EXPECT_TRUE(differs);
}

TEST(Simulator, AngleRandomWalkStatistics) {
  BenchWorld w = idealWorld();
  w.noise.gyro.white = 1e-4;   // rad/sqrt(s)
  w.noise.accel.white = 1e-3;  // m/s/sqrt(s)
  const Simulation s = run(w, twoAxis(200.0, {}, {}), 100.0, 42);
  const Simulation clean = run(idealWorld(), twoAxis(200.0, {}, {}), 100.0, 42);
  const std::size_t n = s.imu.size();
  Vec3 var_g = Vec3::Zero(), var_a = Vec3::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    var_g += (s.imu[k].dtheta - clean.imu[k].dtheta).cwiseAbs2();
    var_a += (s.imu[k].dvel - clean.imu[k].dvel).cwiseAbs2();
  }
  var_g /= static_cast<double>(n);
  var_a /= static_cast<double>(n);
  // Increment sigma = white * sqrt(dt); 20000 samples: the variance is within ~3 %.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(std::sqrt(var_g[i]), 1e-4 * 0.1, 0.05 * 1e-5);
    EXPECT_NEAR(std::sqrt(var_a[i]), 1e-3 * 0.1, 0.05 * 1e-4);
  }
}

TEST(Simulator, GaussMarkovBiasHasItsSteadyStateSigma) {
  BenchWorld w = idealWorld();
  w.noise.gyro.bias_sigma = 1e-5;  // rad/s
  w.noise.gyro.correlation_time_s = 1.0;
  const Motion m = twoAxis(2000.0, {}, {});
  const Simulation s = run(w, m, 100.0, 3);
  const Simulation clean = run(idealWorld(), m, 100.0, 3);
  double var = 0.0, lag_cov = 0.0;
  const std::size_t n = s.imu.size(), lag = 100;  // 1 s = one correlation time
  std::vector<double> b(n);
  for (std::size_t k = 0; k < n; ++k) b[k] = (s.imu[k].dtheta.x() - clean.imu[k].dtheta.x()) / 0.01;
  for (std::size_t k = 0; k < n; ++k) var += b[k] * b[k];
  for (std::size_t k = 0; k + lag < n; ++k) lag_cov += b[k] * b[k + lag];
  var /= static_cast<double>(n);
  lag_cov /= static_cast<double>(n - lag);
  EXPECT_NEAR(std::sqrt(var), 1e-5, 0.15e-5);
  EXPECT_NEAR(lag_cov / var, std::exp(-1.0), 0.1);  // first-order correlation
}

TEST(Simulator, StreamingOnAGrowingMotionEqualsBatch) {
  BenchWorld w = idealWorld();
  w.noise = NoiseModel::navigationGrade();
  w.truth.sensors.gyro.bias = Vec3(1e-6, 0, 0);
  const Motion full = twoAxis(4.0, {0.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0});
  Motion full2 = full;
  full2.axes[1].append({1.5, 0.0, 0.0, 0.4});
  full2.axes[0].append({2.25, 0.0, 0.2, 0.0});
  SimOptions o;
  const Simulation batch = simulate({w, full2}, o);
  ASSERT_TRUE(batch.status.ok);

  Motion growing = full;
  std::string why;
  auto sim = ImuSimulator::Create(w, &growing, o, &why);
  ASSERT_TRUE(sim) << why;
  std::vector<nav::ImuSample> out;
  bool appended1 = false, appended2 = false;
  while (out.size() < batch.imu.size()) {
    // Append each phase only when the simulator is about to need it.
    if (!appended1 && sim->nextPhysicsEnd() > 1.5) {
      growing.axes[1].append({1.5, 0.0, 0.0, 0.4});
      appended1 = true;
    }
    if (!appended2 && sim->nextPhysicsEnd() > 2.25) {
      growing.axes[0].append({2.25, 0.0, 0.2, 0.0});
      appended2 = true;
    }
    out.push_back(sim->next());
  }
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_EQ(out[k].t, batch.imu[k].t);
    EXPECT_EQ(out[k].dtheta, batch.imu[k].dtheta) << k;
    EXPECT_EQ(out[k].dvel, batch.imu[k].dvel) << k;
  }
}

TEST(Simulator, RefusesBadInput) {
  Motion m = twoAxis(1.0, {}, {});
  m.axes.pop_back();
  Simulation s = simulate({idealWorld(), m}, SimOptions{});
  EXPECT_FALSE(s.status.ok);
  EXPECT_NE(s.status.message.find("axes"), std::string::npos) << s.status.message;
  SimOptions o;
  o.imu_rate_hz = 0.0;
  s = simulate({idealWorld(), twoAxis(1.0, {}, {})}, o);
  EXPECT_FALSE(s.status.ok);
  EXPECT_NE(s.status.message.find("imu_rate_hz"), std::string::npos);
  BenchWorld w = idealWorld();
  w.noise.gyro.white = -1.0;
  s = simulate({w, twoAxis(1.0, {}, {})}, SimOptions{});
  EXPECT_FALSE(s.status.ok);
  EXPECT_NE(s.status.message.find("noise.gyro.white"), std::string::npos);
}

TEST(Simulator, ThreeAxisStationaryAtTiltedAttitude) {
  BenchWorld w = idealWorld();
  Motion m;
  m.kind = TableKind::kThreeAxis;
  m.axes.resize(3);
  m.axes[0].append({0.0, 0.3, 0.0, 0.0});
  m.axes[1].append({0.0, 1.1, 0.0, 0.0});
  m.axes[2].append({0.0, -0.7, 0.0, 0.0});
  m.duration = 0.5;
  const Simulation s = run(w, m);
  const Mat3 C = Rz(0.3) * Rx(1.1) * Rz(-0.7);
  const double g = nav::siteGravity(w.site);
  const Vec3 f = C.transpose() * Vec3(0, 0, g) * 0.01;
  const Vec3 om = C.transpose() * nav::earthRateL(kLat) * 0.01;
  EXPECT_LT((s.imu[3].dvel - f).norm(), 1e-14);
  EXPECT_LT((s.imu[3].dtheta - om).norm(), 1e-19);
}

}  // namespace
}  // namespace imubench::calib
