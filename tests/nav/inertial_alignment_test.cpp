// Sway-tolerant (inertial-frame) alignment: recovers a known attitude from exact static data,
// from exact data of a body oscillating about a horizontal axis (a single-axis sway whose
// increments are exact), states the Earth rate's latitude, and refuses a gyro bias far above the
// Earth rate and a span too short. Over many seeds of noisy static, ship and vehicle motion its
// stated heading sigma is honest (every error within 3 of it) and not far too cautious (the
// errors' RMS at least an eighth of it).
#include "nav/inertial_alignment.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "tests/nav/nav_truth.h"

namespace imubench::nav {
namespace {

constexpr double kLat = 47.0 * kDegToRad;

Site site47() {
  return Site{kLat, 100.0, std::nullopt};
}

double headingErrorDeg(const Quat& estimated, const Mat3& C_LB_true) {
  const double d = rollPitchHeading(estimated).z() - rollPitchHeading(Quat(C_LB_true)).z();
  return std::remainder(d, 2.0 * kPi) / kDegToRad;
}

TEST(InertialAlign, StaticExact) {
  test::StationaryTruth truth;
  truth.C_LB = Rz(-2.1) * Rx(0.03) * Ry(-0.02);
  truth.lat_rad = kLat;
  truth.height_m = 100.0;
  ImuSamples s;
  for (int k = 1; k <= 12000; ++k) s.push_back(truth.sample(k * 0.01, 0.01));
  const InertialAlignmentResult r = inertialAlign(s, site47());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LT(std::abs(headingErrorDeg(r.q_BtoL_start, truth.C_LB)), 1e-4);
  EXPECT_NEAR(r.implied_latitude_rad, kLat, 1e-5);
  EXPECT_LT(r.residual_rms_rad, 1e-8);
}

// Single-axis sway about the Earth-fixed East axis through the IMU: C_LB(t) = R(E, a sin(w t))
// C0. Exact increments from piecewise-constant-rate steps of the fixed-axis truth.
TEST(InertialAlign, SwayExact) {
  const Mat3 C0 = Rz(-0.7);
  const double amp = 3.0 * kDegToRad, period = 7.3, dt = 0.01;
  ImuSamples s;
  Mat3 C = C0;
  for (int k = 1; k <= 9000; ++k) {
    const double t1 = k * dt, t0 = t1 - dt;
    const double angle0 = amp * std::sin(2 * kPi * t0 / period);
    const double angle1 = amp * std::sin(2 * kPi * t1 / period);
    test::FixedAxisTurnTruth step;
    step.C0 = C;
    step.u_L = Vec3::UnitX();
    step.rate = (angle1 - angle0) / dt;
    step.lat_rad = kLat;
    step.height_m = 100.0;
    if (step.rate == 0.0) step.rate = 1e-12;
    ImuSample x = step.sample(dt, dt);
    x.t = t1;
    s.push_back(x);
    C = step.C_LB(dt);
  }
  const InertialAlignmentResult r = inertialAlign(s, site47());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LT(std::abs(headingErrorDeg(r.q_BtoL_start, C0)), 0.01);
  EXPECT_GT(r.sway_peak_rad, 2.0 * kDegToRad);
  EXPECT_LT(r.sigma_heading_rad, 0.01 * kDegToRad);
}

TEST(InertialAlign, RefusesGyroBiasFarAboveEarthRate) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat;
  truth.height_m = 100.0;
  truth.gyro_bias_B = Vec3(0.5, -0.3, 0.2) * kDegToRad;  // a consumer MEMS gyro's, deg/s
  ImuSamples s;
  for (int k = 1; k <= 9000; ++k) s.push_back(truth.sample(k * 0.01, 0.01));
  const InertialAlignmentResult r = inertialAlign(s, site47());
  EXPECT_EQ(r.status, AlignmentStatus::kRateTooLarge) << r.message;
  EXPECT_NE(r.message.find("gyro bias"), std::string::npos);
}

TEST(InertialAlign, RefusesShortSpan) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat;
  ImuSamples s;
  for (int k = 1; k <= 1000; ++k) s.push_back(truth.sample(k * 0.01, 0.01));
  EXPECT_EQ(inertialAlign(s, site47()).status, AlignmentStatus::kTooShort);
}

// A body on the Earth swaying in attitude (roll, pitch and yaw sinusoids about a heading) while
// its point oscillates in the local level frame (surge, sway, heave: a bounded velocity), with
// navigation-grade white noise. Increments: the exact rotation between the sample ends against
// inertial space, the specific force integrated by Simpson's rule.
struct SwayCase {
  const char* name;
  double lat_deg, heading_deg, duration_s;
  std::array<double, 3> att_amp_deg, att_period_s;  // roll, pitch, yaw
  std::array<double, 3> acc_amp, acc_period_s;      // East, North, Up (m/s^2)
};

struct SwayTruth {
  const SwayCase& c;
  std::array<double, 6> phase;

  Mat3 C_LB(double t) const {
    std::array<double, 3> a{};
    for (std::size_t i = 0; i < 3; ++i)
      a[i] = c.att_amp_deg[i] * kDegToRad * std::sin(2 * kPi * t / c.att_period_s[i] + phase[i]);
    return Rz(-c.heading_deg * kDegToRad) * Rz(a[2]) * Rx(a[1]) * Ry(a[0]);
  }
  Vec3 f_B(double t, double g) const {
    Vec3 acc;
    for (int i = 0; i < 3; ++i) {
      const auto k = static_cast<std::size_t>(i);
      acc(i) = c.acc_amp[k] * std::sin(2 * kPi * t / c.acc_period_s[k] + phase[k + 3]);
    }
    return C_LB(t).transpose() * (Vec3(0.0, 0.0, g) + acc);
  }
};

ImuSamples swaySamples(const SwayTruth& truth, std::mt19937& rng) {
  const double lat = truth.c.lat_deg * kDegToRad, g = normalGravity(lat, 0.0), dt = 0.01;
  const Mat3 earth_turn =
      Eigen::AngleAxisd(kEarthRate * dt, earthRateL(lat).normalized()).toRotationMatrix();
  std::normal_distribution<double> gyro(0.0, 5.8e-6 * dt), accel(0.0, 2e-3 * dt);
  ImuSamples s;
  for (int k = 1; k * dt <= truth.c.duration_s + 1e-9; ++k) {
    const double t1 = k * dt, t0 = t1 - dt;
    ImuSample x;
    x.t = t1;
    const Mat3 dC = truth.C_LB(t0).transpose() * earth_turn * truth.C_LB(t1);
    x.dtheta = rotationVectorFromQuat(Quat(dC)) + Vec3(gyro(rng), gyro(rng), gyro(rng));
    x.dvel = dt / 6.0 * (truth.f_B(t0, g) + 4.0 * truth.f_B(t0 + 0.5 * dt, g) + truth.f_B(t1, g)) +
             Vec3(accel(rng), accel(rng), accel(rng));
    s.push_back(x);
  }
  return s;
}

// For each case, over 12 seeds (random sway phases and noise): every heading error within 3
// stated sigmas, and their RMS at least an eighth of the mean stated sigma (static 0.053 deg
// RMS for 0.055 stated, vehicle 0.054 for 0.058, ship 0.32 for 1.9: its 9.7 s surge beats
// against the 11.4 s windows, and the sigma takes the beat for as large as the sway's
// velocity). The old fit (box blocks, their scatter taken for white noise) stated half the
// static case's RMS error (one error 3.3 sigmas out) while its ship and vehicle errors were
// 5.4 and 0.92 deg RMS (stated 14 and 2.3).
TEST(InertialAlign, StatedHeadingSigmaMatchesTheScatterOverSeeds) {
  const std::array<SwayCase, 3> cases{{
      {"static", 40.0, 63.0, 200.0, {0, 0, 0}, {1, 1, 1}, {0, 0, 0}, {1, 1, 1}},
      {"ship",
       55.0,
       301.0,
       240.0,
       {5.0, 2.0, 1.0},
       {10.7, 7.9, 13.3},
       {0.1, 0.25, 0.6},
       {11.1, 9.7, 7.3}},
      {"vehicle",
       -20.0,
       160.0,
       150.0,
       {1.2, 0.8, 0.4},
       {1.1, 1.7, 2.9},
       {0.1, 0.1, 1.2},
       {3.1, 2.3, 0.7}},
  }};
  for (const SwayCase& c : cases) {
    double ss_err = 0.0, sum_sigma = 0.0, worst_ratio = 0.0;
    constexpr int kSeeds = 12;
    for (int seed = 0; seed < kSeeds; ++seed) {
      std::mt19937 rng(static_cast<unsigned>(1000 + seed));
      std::uniform_real_distribution<double> ph(0.0, 2 * kPi);
      const SwayTruth truth{c, {ph(rng), ph(rng), ph(rng), ph(rng), ph(rng), ph(rng)}};
      const ImuSamples s = swaySamples(truth, rng);
      const InertialAlignmentResult r =
          inertialAlign(s, Site{c.lat_deg * kDegToRad, 0.0, std::nullopt});
      ASSERT_TRUE(r.ok()) << c.name << " seed " << seed << ": " << r.message;
      const double err = std::abs(headingErrorDeg(r.q_BtoL_start, truth.C_LB(0.0)));
      const double sigma = r.sigma_heading_rad / kDegToRad;
      ss_err += err * err;
      sum_sigma += sigma;
      worst_ratio = std::max(worst_ratio, err / sigma);
    }
    const double rms = std::sqrt(ss_err / kSeeds), mean_sigma = sum_sigma / kSeeds;
    RecordProperty(std::string(c.name) + "_rms_error_deg", test::fmt(rms));
    RecordProperty(std::string(c.name) + "_mean_sigma_deg", test::fmt(mean_sigma));
    EXPECT_LE(worst_ratio, 3.0) << c.name << ": an error beyond 3 stated sigmas";
    EXPECT_GE(rms, mean_sigma / 8.0)
        << c.name << ": stated sigma " << mean_sigma << " deg, RMS error " << rms << " deg";
  }
}

}  // namespace
}  // namespace imubench::nav
