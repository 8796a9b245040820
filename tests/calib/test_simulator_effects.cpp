// The simulator with each effect added by this registry switched on: the recording differs
// from the one without it by the model's term, computed independently where the term is
// simple. And the truth file's "extra" round trip for every effect id.
#include <gtest/gtest.h>

#include <cmath>

#include "calib/bench_truth.h"
#include "calib/simulator.h"
#include "tests/calib/sim_fixtures.h"

namespace imubench::calib {
namespace {

using testing::delayTestMotion;
using testing::idealWorld;
using testing::kLat;
using testing::largestDifference;
using testing::twoAxis;

constexpr double kRate = 100.0;
constexpr double kDt = 1.0 / kRate;

Simulation run(const BenchWorld& w, const Motion& m, std::uint64_t seed = 1) {
  return testing::simulateOk(w, m, kRate, seed);
}

TEST(SimulatorEffects, SizeEffectAtConstantRateIsTheCentripetalDifference) {
  // Outer axis (x = East, B x stays East) at constant rate w: w_LB_B = (w, 0, 0), so at a
  // point d the centripetal specific force is -w^2 (0, d_y, d_z). Axis y senses it at d_y
  // relative to the x point, axis z at d_z; axis x is unchanged. With a lever arm on, the
  // difference stays the size effect's (it is relative to the x point).
  const double w = 90.0 * kDegToRad;
  const Motion m = twoAxis(2.0, {0.0, 0.0, w, 0.0}, {});
  const Vec3 d_y(0.01, 0.02, -0.015), d_z(-0.02, 0.01, 0.03);
  BenchWorld off = idealWorld();
  off.truth.extra.lever_arm = LeverArm{Vec3(0.05, -0.04, 0.03)};
  BenchWorld on = off;
  on.truth.extra.size_effect = SizeEffect{d_y, d_z};
  const Simulation a = run(on, m), b = run(off, m);
  for (std::size_t k : {std::size_t{3}, std::size_t{77}, std::size_t{150}}) {
    const Vec3 diff = (a.imu[k].dvel - b.imu[k].dvel) / kDt;
    EXPECT_NEAR(diff.x(), 0.0, 1e-12);
    EXPECT_NEAR(diff.y(), -w * w * d_y.y(), 1e-12);
    EXPECT_NEAR(diff.z(), -w * w * d_z.z(), 1e-12);
    EXPECT_LT((a.imu[k].dtheta - b.imu[k].dtheta).norm(), 1e-18);
  }
}

TEST(SimulatorEffects, AccelDelayShiftsOnlyTheAccelerometers) {
  // Accelerometers delayed by tau see what undelayed ones see on a motion tau later; the
  // gyros are those of the undelayed motion.
  const double tau = 0.0043;
  BenchWorld delayed = idealWorld();
  delayed.truth.extra.accel_delay = AccelDelay{tau};
  const Simulation a = run(delayed, delayTestMotion());
  const Simulation later = run(idealWorld(), delayTestMotion(tau));
  const Simulation now = run(idealWorld(), delayTestMotion());
  EXPECT_LT(largestDifference(a, later, &now), 1e-13);
  EXPECT_GT(largestDifference(a, now), 1e-5);
  // With time_delay too, the accelerometers are tau_s + accel tau behind the table clock.
  BenchWorld both = delayed;
  both.truth.extra.time_delay = TimeDelay{0.002};
  const Simulation c = run(both, delayTestMotion());
  const Simulation c_ref = run(idealWorld(), delayTestMotion(tau + 0.002));
  EXPECT_LT(largestDifference(c, c_ref), 1e-13);
}

TEST(SimulatorEffects, AngleHarmonicAddsItsAngleErrorToTheGyro) {
  // Outer axis (East) at constant encoder rate: the true angle is a + e(a), so the x gyro
  // integrates e(a1) - e(a0) more over a sample (a = encoder angle at its ends). Earth rate
  // has no East component, so the x channel difference is exactly that.
  const double w = 30.0 * kDegToRad, c = 4e-4, s = -3e-4;
  const int order = 3;
  const Motion m = twoAxis(2.0, {0.0, 0.0, w, 0.0}, {});
  BenchWorld on = idealWorld();
  on.truth.extra.angle_harmonic = AngleHarmonic{kTableAxisOuter, order, c, s};
  const Simulation a = run(on, m), b = run(idealWorld(), m);
  const auto e = [&](double angle) {
    return c * std::cos(order * angle) + s * std::sin(order * angle);
  };
  for (std::size_t k : {std::size_t{0}, std::size_t{41}, std::size_t{133}}) {
    const double a1 = w * a.imu[k].t, a0 = a1 - w * kDt;
    EXPECT_NEAR(a.imu[k].dtheta.x() - b.imu[k].dtheta.x(), e(a1) - e(a0), 1e-15);
  }
  // The encoder log is what the encoders read (unchanged).
  EXPECT_EQ(a.table[50].angles.outer, b.table[50].angles.outer);
  // No middle axis on a two-axis table: refused.
  BenchWorld bad = idealWorld();
  bad.truth.extra.angle_harmonic = AngleHarmonic{kTableAxisMiddle, 1, c, s};
  const Simulation r = simulate({bad, m}, SimOptions{});
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("angle_harmonic"), std::string::npos);
}

TEST(SimulatorEffects, TableEffectsAreTheTableErrors) {
  // Each table effect adds its parameters to the truth's table errors: a recording with the
  // effect equals one with the same errors in truth.table, and differs from one without.
  const Motion m = twoAxis(1.0, {0.0, 0.3, 0.5, 0.1}, {0.0, -0.2, 0.4, 0.0});
  BenchWorld base = idealWorld();
  base.truth.table.base_tilt = Vec2(1e-5, 2e-5);
  base.truth.table.encoder_zero.inner = 3e-5;
  const Simulation plain = run(base, m);
  struct Case {
    EffectId id;
    std::vector<double> params;
    TableErrors errors;  // base + params
  };
  TableErrors tilt = base.truth.table, nonorth = tilt, zero = tilt, mount = tilt;
  tilt.base_tilt += Vec2(2e-4, -1e-4);
  nonorth.nonorthogonality.inner_y += 3e-4;
  zero.encoder_zero.outer += -2e-4;
  zero.encoder_zero.inner += 1e-4;
  mount.mounting += Vec2(-1e-4, 2e-4);
  const Case cases[] = {{EffectId::kBaseTilt, {2e-4, -1e-4}, tilt},
                        {EffectId::kNonorthogonality, {3e-4, 0.0, 0.0}, nonorth},
                        {EffectId::kEncoderZero, {-2e-4, 0.0, 1e-4}, zero},
                        {EffectId::kMounting, {-1e-4, 2e-4}, mount}};
  for (const Case& c : cases) {
    BenchWorld on = base;
    std::string why;
    ASSERT_TRUE(on.truth.extra.setFlat(c.id, c.params, &why)) << why;
    BenchWorld ref = base;
    ref.truth.table = c.errors;
    const Simulation a = run(on, m), b = run(ref, m);
    EXPECT_LT(largestDifference(a, b, &b), 1e-15) << effectName(c.id);
    EXPECT_GT(largestDifference(a, plain), 1e-7) << effectName(c.id);
  }
}

TEST(SimulatorEffects, BaseTiltAtRestTiltsGravity) {
  // Independent check of one table effect: at rest at zero angles (C_LB = exp([theta x]) on a
  // two-axis table heading East), f_B = C_LB^T (0, 0, g) = g (-theta_y, theta_x, 1) to first
  // order.
  const double tx = 2e-4, ty = -3e-4;
  BenchWorld on = idealWorld();
  on.truth.extra.base_tilt = BaseTilt{tx, ty};
  const Simulation a = run(on, twoAxis(0.5, {}, {}));
  const double g = nav::siteGravity(on.site);
  const Vec3 f = a.imu[10].dvel / kDt;
  EXPECT_NEAR(f.x(), -g * ty, g * 1e-7);
  EXPECT_NEAR(f.y(), g * tx, g * 1e-7);
}

// Overlapping Allan deviation of a rate series y (sample step dt) at m samples per cluster.
double allanDeviation(const std::vector<double>& y, int m, double dt) {
  std::vector<double> theta(y.size() + 1, 0.0);  // integral of y
  for (std::size_t k = 0; k < y.size(); ++k) theta[k + 1] = theta[k] + y[k] * dt;
  const double tau = m * dt;
  double sum = 0.0;
  std::size_t n = 0;
  const auto um = static_cast<std::size_t>(m);
  for (std::size_t k = 0; k + 2 * um < theta.size(); ++k) {
    const double d = theta[k + 2 * um] - 2.0 * theta[k + um] + theta[k];
    sum += d * d;
    ++n;
  }
  return std::sqrt(sum / (2.0 * tau * tau * static_cast<double>(n)));
}

TEST(SimulatorEffects, BiasInstabilityHasItsAllanMinimumAtTau) {
  // The drift is the only difference between recordings with and without the effect (its
  // random stream is its own), even with the noise model on; its Allan deviation peaks at
  // tau_s with the given value on every axis.
  const double tau = 0.5;
  const Vec3 b_accel(2e-4, 4e-4, 1e-4), b_gyro(1e-5, 3e-6, 6e-6);
  BenchWorld off = idealWorld();
  off.noise = NoiseModel::tactical();
  BenchWorld on = off;
  on.truth.extra.bias_instability = BiasInstability{b_accel, b_gyro, tau};
  const Motion m = twoAxis(300.0, {}, {});
  const Simulation a = run(on, m, 5), b = run(off, m, 5);
  ASSERT_EQ(a.imu.size(), b.imu.size());
  const int cluster = static_cast<int>(std::lround(tau / kDt));
  for (int ch = 0; ch < 6; ++ch) {
    std::vector<double> y(a.imu.size());
    for (std::size_t k = 0; k < y.size(); ++k) {
      y[k] = ch < 3 ? (a.imu[k].dvel - b.imu[k].dvel)[ch] / kDt
                    : (a.imu[k].dtheta - b.imu[k].dtheta)[ch - 3] / kDt;
    }
    const double expected = ch < 3 ? b_accel[ch] : b_gyro[ch - 3];
    const double at_tau = allanDeviation(y, cluster, kDt);
    EXPECT_NEAR(at_tau, expected, 0.12 * expected) << "channel " << ch;
    EXPECT_LT(allanDeviation(y, cluster / 10, kDt), at_tau) << "channel " << ch;
    EXPECT_LT(allanDeviation(y, cluster * 10, kDt), at_tau) << "channel " << ch;
  }
}

// A valid, distinctive flat vector for every effect id.
std::vector<double> distinctive(EffectId id) {
  std::vector<double> v;
  int k = 0;
  for (const ParamSpec& p : paramSpecs(id)) {
    for (int e = 0; e < paramSize(p.shape); ++e, ++k) {
      switch (p.kind) {
        case ParamKind::kReal:
          v.push_back(1e-4 * (k + 1) * (k % 2 ? -1.0 : 1.0) + 0.25 * static_cast<int>(id));
          break;
        case ParamKind::kInteger:
          v.push_back(3.0);
          break;
        case ParamKind::kTableAxis:
          v.push_back(kTableAxisInner);
          break;
      }
    }
  }
  return v;
}

TEST(SimulatorEffects, TruthJsonRoundTripsEveryEffectByItsInterchangeNames) {
  BenchTruth t;
  std::string why;
  for (EffectId id : kAllEffects) {
    ASSERT_TRUE(t.extra.setFlat(id, distinctive(id), &why)) << why;
  }
  const nlohmann::json j = toJson(t);
  for (EffectId id : kAllEffects) {
    const nlohmann::json& e = j.at("extra").at(effectName(id));
    EXPECT_EQ(e.size(), paramSpecs(id).size()) << effectName(id);
    for (const ParamSpec& p : paramSpecs(id)) EXPECT_TRUE(e.contains(p.name)) << p.name;
  }
  EXPECT_EQ(j["extra"]["angle_harmonic"]["axis"], "inner");
  EXPECT_TRUE(j["extra"]["angle_harmonic"]["order"].is_number_integer());
  EXPECT_EQ(j["extra"]["size_effect"]["d_z_m"].size(), 3u);
  BenchTruth back;
  ASSERT_TRUE(fromJson(nlohmann::json::parse(j.dump()), &back, &why)) << why;
  for (EffectId id : kAllEffects) {
    ASSERT_TRUE(back.extra.has(id)) << effectName(id);
    EXPECT_EQ(back.extra.flat(id), t.extra.flat(id)) << effectName(id);
  }
  EXPECT_EQ(flatNames(back), flatNames(t));
}

TEST(SimulatorEffects, TruthJsonRefusesBadDiscreteEffectParameters) {
  const std::pair<const char*, const char*> bad[] = {
      {R"({"extra": {"angle_harmonic": {"axis": "sideways"}}})", "extra.angle_harmonic.axis"},
      {R"({"extra": {"angle_harmonic": {"axis": 1}}})", "extra.angle_harmonic.axis"},
      {R"({"extra": {"angle_harmonic": {"order": 2.5}}})", "extra.angle_harmonic.order"},
      {R"({"extra": {"angle_harmonic": {"order": 0}}})", "extra.angle_harmonic.order"},
      {R"({"extra": {"size_effect": {"d_y_m": [1, 2]}}})", "extra.size_effect.d_y_m"},
      {R"({"extra": {"bias_instability": {"tau": 1}}})", "extra.bias_instability.tau"},
  };
  for (const auto& [text, where] : bad) {
    BenchTruth t;
    std::string why;
    EXPECT_FALSE(fromJson(nlohmann::json::parse(text), &t, &why)) << text;
    EXPECT_EQ(why.rfind(where, 0), 0u) << why;
  }
}

TEST(SimulatorEffects, EffectParametersFromCommandLineText) {
  EffectSet fx;
  std::string why;
  ASSERT_TRUE(setEffectParamFromText(&fx, "lever_arm.r_m=0.05,-0.03,2e-2", &why)) << why;
  EXPECT_EQ(fx.lever_arm->r_m, Vec3(0.05, -0.03, 0.02));
  ASSERT_TRUE(setEffectParamFromText(&fx, "angle_harmonic.axis=inner", &why)) << why;
  ASSERT_TRUE(setEffectParamFromText(&fx, "angle_harmonic.order=4", &why)) << why;
  EXPECT_EQ(fx.angle_harmonic->axis, kTableAxisInner);
  EXPECT_EQ(fx.angle_harmonic->order, 4.0);
  ASSERT_TRUE(setEffectParamFromText(&fx, "gyro_g_sensitivity.G=1,2,3,4,5,6,7,8,9", &why));
  EXPECT_EQ(fx.gyro_g_sensitivity->G(0, 2), 3.0);
  const std::pair<const char*, const char*> bad[] = {
      {"lever_arm.r_m=1,2", "expected 3 numbers"},
      {"lever_arm=1", "expected <effect>.<parameter>"},
      {"lever.r_m=1,2,3", "unknown effect id"},
      {"lever_arm.r=1,2,3", "unknown parameter"},
      {"time_delay.tau_s=1ms", "not a number"},
      {"angle_harmonic.order=0.5", "integer"},
      {"time_delay.tau_s=inner", "not a number"},
      {"angle_harmonic.axis=2", "not outer, middle or inner"},
  };
  for (const auto& [text, msg] : bad) {
    EXPECT_FALSE(setEffectParamFromText(&fx, text, &why)) << text;
    EXPECT_NE(why.find(msg), std::string::npos) << why;
  }
}

}  // namespace
}  // namespace imubench::calib
