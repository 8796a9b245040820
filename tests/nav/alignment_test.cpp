// Coarse alignment: recovers a known attitude from exact static data, fails cleanly on
// moving or bad data.
#include "nav/alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/nav/nav_truth.h"

namespace imubench::nav {
namespace {

constexpr double kLat = 58.0 * kDegToRad;

ImuSamples staticSpan(const test::StationaryTruth& truth, double rate, double duration) {
  ImuSamples out;
  const double dt = 1.0 / rate;
  const long n = std::lround(duration * rate);
  for (long k = 1; k <= n; ++k) out.push_back(truth.sample(100.0 + k * dt, dt));
  return out;
}

Site site58() {
  return Site{kLat, 100.0, std::nullopt};
}

TEST(RollPitchHeading, DecomposesTheDocumentedSequence) {
  const double roll = 0.1, pitch = -0.2, heading = 2.5;
  const Quat q(Rz(-heading) * Rx(pitch) * Ry(roll));
  const Vec3 rph = rollPitchHeading(q);
  EXPECT_NEAR(rph.x(), roll, 1e-12);
  EXPECT_NEAR(rph.y(), pitch, 1e-12);
  EXPECT_NEAR(rph.z(), heading, 1e-12);
}

class AlignExact : public ::testing::TestWithParam<Vec3> {};  // (roll, pitch, heading) deg

TEST_P(AlignExact, RecoversAttitude) {
  const Vec3 rph_deg = GetParam();
  const Vec3 rph = rph_deg * kDegToRad;
  test::StationaryTruth truth;
  truth.C_LB = Rz(-rph.z()) * Rx(rph.y()) * Ry(rph.x());
  truth.lat_rad = kLat;
  truth.height_m = 100.0;
  const ImuSamples s = staticSpan(truth, 100.0, 30.0);
  const AlignmentResult r = coarseAlign(s, site58());
  ASSERT_TRUE(r.ok()) << r.message;
  const Vec3 est = rollPitchHeading(r.q_BtoL);
  EXPECT_NEAR(est.x(), rph.x(), 1e-9);
  EXPECT_NEAR(est.y(), rph.y(), 1e-9);
  EXPECT_NEAR(std::remainder(est.z() - rph.z(), 2.0 * kPi), 0.0, 1e-9);
  EXPECT_NEAR(r.duration_s, 30.0, 1e-9);
  EXPECT_LT(test::attitudeErrorRad(r.q_BtoL, Quat(truth.C_LB)), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Attitudes, AlignExact,
                         ::testing::Values(Vec3(0.0, 0.0, 0.0), Vec3(5.0, -3.0, 45.0),
                                           Vec3(-30.0, 20.0, 170.0), Vec3(10.0, 60.0, -100.0),
                                           Vec3(175.0, 10.0, 30.0)),  // upside down
                         [](const ::testing::TestParamInfo<Vec3>& param_info) {
                           return "case" + std::to_string(param_info.index);
                         });

// Heading is as good as Earth rate allows: a gyro bias b_E along (levelled) East gives a
// heading error of b_E / (W cos lat); roll/pitch stay exact (they use gravity only).
TEST(Align, HeadingErrorFollowsEastGyroBias) {
  test::StationaryTruth truth;
  truth.C_LB = Rz(-0.7) * Rx(0.05) * Ry(-0.03);
  truth.lat_rad = kLat;
  truth.height_m = 100.0;
  const double b = 0.01 * kDegPerHourToRadPerSec;
  truth.gyro_bias_B = truth.C_LB.transpose() * Vec3(b, 0.0, 0.0);
  const AlignmentResult r = coarseAlign(staticSpan(truth, 100.0, 60.0), site58());
  ASSERT_TRUE(r.ok()) << r.message;
  const Vec3 est = rollPitchHeading(r.q_BtoL);
  const double expected = b / (kEarthRate * std::cos(kLat));  // ~ 1.5 mrad
  EXPECT_NEAR(std::abs(est.z() - 0.7), expected, 0.02 * expected);
  EXPECT_NEAR(est.x(), -0.03, 1e-9);
  EXPECT_NEAR(est.y(), 0.05, 1e-9);
}

TEST(Align, NoisyNavGradeDataGivesArcsecondLevelling) {
  test::StationaryTruth truth;
  truth.C_LB = Rz(1.1) * Rx(0.02) * Ry(0.01);
  truth.lat_rad = kLat;
  ImuSamples s = staticSpan(truth, 200.0, 60.0);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> n01;
  const double dt = 1.0 / 200.0;
  // Accel white noise 20 ug/sqrt(Hz), gyro ARW 0.002 deg/sqrt(h): per-sample increments.
  const double sv = 20e-6 * 9.81 * std::sqrt(dt);
  const double sth = 0.002 * kDegToRad / 60.0 * std::sqrt(dt);
  for (auto& x : s) {
    x.dvel += sv * Vec3(n01(rng), n01(rng), n01(rng));
    x.dtheta += sth * Vec3(n01(rng), n01(rng), n01(rng));
  }
  const AlignmentResult r = coarseAlign(s, Site{kLat, 0.0, std::nullopt});
  ASSERT_TRUE(r.ok()) << r.message;
  // Level error ~ noise / (g sqrt(T)) = 20e-6 / sqrt(60) rad ~ 0.5 arcsec.
  const Mat3 dC = r.C_LB * truth.C_LB.transpose();
  const double tilt = std::hypot(dC(2, 0), dC(2, 1));
  EXPECT_LT(tilt * kRadToArcsec, 3.0);
}

TEST(Align, FailsOnTableRotation) {
  test::FixedAxisTurnTruth turn;
  turn.u_L = Vec3::UnitZ();
  turn.rate = 1.0 * kDegToRad;  // a slow 1 deg/s turn
  turn.lat_rad = kLat;
  ImuSamples s;
  for (int k = 1; k <= 2000; ++k) s.push_back(turn.sample(k * 0.01, 0.01));
  const AlignmentResult r = coarseAlign(s, site58());
  // A steady turn about the vertical leaves block means equal; the rate check catches it.
  EXPECT_EQ(r.status, AlignmentStatus::kRateTooLarge) << r.message;
  EXPECT_NE(r.message.find("rotating"), std::string::npos) << r.message;
}

TEST(Align, FailsOnTiltingMotion) {
  test::FixedAxisTurnTruth turn;
  turn.u_L = Vec3::UnitX();
  turn.rate = 2.0 * kDegToRad;
  turn.lat_rad = kLat;
  ImuSamples s;
  for (int k = 1; k <= 1000; ++k) s.push_back(turn.sample(k * 0.01, 0.01));
  const AlignmentResult r = coarseAlign(s, site58());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, AlignmentStatus::kNotStatic) << r.message;
}

TEST(Align, FailsOnShortSpan) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat;
  const AlignmentResult r = coarseAlign(staticSpan(truth, 100.0, 0.5), site58());
  EXPECT_EQ(r.status, AlignmentStatus::kTooShort);
  EXPECT_NE(r.message.find("at least 1"), std::string::npos) << r.message;
  const AlignmentResult r2 = coarseAlign(ImuSamples(3), site58());
  EXPECT_EQ(r2.status, AlignmentStatus::kTooShort) << r2.message;
}

TEST(Align, FailsOnBadTimestampsAndNaN) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat;
  ImuSamples s = staticSpan(truth, 100.0, 5.0);
  ImuSamples back = s;
  back[200].t = back[199].t;
  EXPECT_EQ(coarseAlign(back, site58()).status, AlignmentStatus::kBadTimestamps);
  s[10].dvel.x() = std::nan("");
  EXPECT_FALSE(coarseAlign(s, site58()).ok());
}

TEST(Align, FailsOnWrongGravityAndLargeRate) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat;
  truth.accel_bias_B = Vec3(0.0, 0.0, 0.5);  // 5 % off
  EXPECT_EQ(coarseAlign(staticSpan(truth, 100.0, 5.0), site58()).status,
            AlignmentStatus::kGravityMismatch);
  truth.accel_bias_B.setZero();
  truth.gyro_bias_B = Vec3(0.0, 0.0, 50.0 * kDegPerHourToRadPerSec);
  EXPECT_EQ(coarseAlign(staticSpan(truth, 100.0, 5.0), site58()).status,
            AlignmentStatus::kRateTooLarge);
}

TEST(Align, HeadingUnobservableAtPole) {
  const AlignmentResult r =
      alignFromMeans(Vec3(0.0, 0.0, 9.83), Vec3(0.0, 0.0, kEarthRate), 89.99 * kDegToRad);
  EXPECT_EQ(r.status, AlignmentStatus::kHeadingUnobservable);
  EXPECT_FALSE(r.message.empty());
}

TEST(Align, InvalidOptionsReported) {
  AlignmentOptions opt;
  opt.static_blocks = 1;
  std::string why;
  EXPECT_FALSE(opt.IsValid(&why));
  test::StationaryTruth truth;
  EXPECT_EQ(coarseAlign(staticSpan(truth, 100.0, 5.0), site58(), opt).status,
            AlignmentStatus::kInvalidOptions);
}

}  // namespace
}  // namespace imubench::nav
