// Sway-tolerant (inertial-frame) alignment: recovers a known attitude from exact static data,
// from exact data of a body oscillating about a horizontal axis (a single-axis sway whose
// increments are exact), states the Earth rate's latitude, and refuses a gyro bias far above the
// Earth rate and a span too short.
#include "nav/inertial_alignment.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace imubench::nav
