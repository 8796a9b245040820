// Free navigation: output series, displacement frame, streaming == batch, input errors.
#include "nav/free_navigation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/nav/nav_truth.h"

namespace imubench::nav {
namespace {

constexpr double kLat = 58.0 * kDegToRad;

ImuSamples stationary(const test::StationaryTruth& truth, double t0, double rate, double duration) {
  ImuSamples out;
  const double dt = 1.0 / rate;
  const long n = std::lround(duration * rate);
  for (long k = 1; k <= n; ++k) out.push_back(truth.sample(t0 + k * dt, dt));
  return out;
}

test::StationaryTruth tilted() {
  test::StationaryTruth truth;
  truth.C_LB = Rz(0.3) * Rx(0.1) * Ry(-0.2);
  truth.lat_rad = kLat;
  truth.height_m = 100.0;
  return truth;
}

const Site kSite{kLat, 100.0, std::nullopt};

TEST(FreeNav, StationaryErrorFreeStaysAtZeroAndDecimates) {
  const auto truth = tilted();
  const ImuSamples s = stationary(truth, 50.0, 100.0, 120.0);
  FreeNavOptions opt;
  opt.output_interval_s = 10.0;
  const FreeNavResult r =
      navigateFree(stationaryState(firstIntervalStart(s), Quat(truth.C_LB), kSite), s, opt);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.samples_used, s.size());
  ASSERT_EQ(r.series.size(), 13u);  // t0 and every 10 s
  for (std::size_t i = 0; i < r.series.size(); ++i) {
    EXPECT_NEAR(r.series[i].t, 50.0 + 10.0 * static_cast<double>(i), 1e-9);
    EXPECT_LT(std::hypot(r.series[i].d_E_m, r.series[i].d_N_m), 1e-6);
    EXPECT_LT(std::hypot(r.series[i].v_E_err, r.series[i].v_N_err), 1e-8);
    EXPECT_LT(test::attitudeErrorRad(r.series[i].q_BtoL, Quat(truth.C_LB)), 1e-10);
  }
  EXPECT_NEAR(r.final_state.t, 170.0, 1e-9);
}

// A constant accelerometer bias pointing North-East moves the solution the right way:
// over 60 s (<< Schuler period) v = b t and d = b t^2 / 2 in the start-point level frame.
TEST(FreeNav, AccelBiasGivesQuadraticDisplacementInStartFrame) {
  auto truth = tilted();
  const Vec3 b_L(2e-3, -1e-3, 0.0);
  truth.accel_bias_B = truth.C_LB.transpose() * b_L;
  const ImuSamples s = stationary(truth, 0.0, 200.0, 60.0);
  FreeNavOptions opt;
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, opt);
  ASSERT_TRUE(r.ok()) << r.message;
  const NavErrorPoint& p = r.series.back();
  EXPECT_NEAR(p.t, 60.0, 1e-9);
  // Schuler bends the curve by (w_s t)^2 / 12 ~ 0.05 %; Coriolis by ~ W t ~ 0.4 % crosswise.
  EXPECT_NEAR(p.v_E_err, b_L.x() * 60.0, 0.01 * 0.12);
  EXPECT_NEAR(p.v_N_err, b_L.y() * 60.0, 0.01 * 0.12);
  EXPECT_NEAR(p.d_E_m, 0.5 * b_L.x() * 3600.0, 0.01 * 3.6);
  EXPECT_NEAR(p.d_N_m, 0.5 * b_L.y() * 3600.0, 0.01 * 3.6);
  EXPECT_EQ(p.v_U_err, 0.0);  // hold height
}

TEST(FreeNav, ReferenceVelocityIsSubtracted) {
  const auto truth = tilted();
  const ImuSamples s = stationary(truth, 0.0, 100.0, 1.0);
  FreeNavOptions opt;
  opt.reference_v_L = Vec3(0.5, -0.25, 0.0);
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, opt);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.series.back().v_E_err, -0.5, 1e-9);
  EXPECT_NEAR(r.series.back().v_N_err, 0.25, 1e-9);
}

TEST(FreeNav, StreamingEqualsBatch) {
  auto truth = tilted();
  truth.gyro_bias_B = Vec3(1e-7, -2e-7, 3e-7);
  truth.accel_bias_B = Vec3(1e-4, 2e-4, -1e-4);
  const ImuSamples s = stationary(truth, 0.0, 100.0, 300.0);
  FreeNavOptions opt;
  opt.output_interval_s = 2.5;
  const NavState init = stationaryState(0.0, Quat(truth.C_LB), kSite);
  const FreeNavResult batch = navigateFree(init, s, opt);
  ASSERT_TRUE(batch.ok());
  FreeNavigator nav(init, opt);
  std::vector<NavErrorPoint> stream{nav.initialPoint()};
  for (const auto& x : s) {
    const auto fr = nav.feed(x);
    ASSERT_EQ(fr.status, FreeNavStatus::kOk);
    if (fr.output) stream.push_back(*fr.output);
  }
  ASSERT_EQ(stream.size(), batch.series.size());
  ASSERT_EQ(stream.size(), 121u);
  for (std::size_t i = 0; i < stream.size(); ++i) {
    EXPECT_EQ(stream[i].t, batch.series[i].t);
    EXPECT_EQ(stream[i].d_E_m, batch.series[i].d_E_m);
    EXPECT_EQ(stream[i].v_N_err, batch.series[i].v_N_err);
  }
  // The biases did move the solution (the comparison is not between zeros).
  EXPECT_GT(std::abs(batch.series.back().d_E_m), 1.0);
}

TEST(FreeNav, RejectsNonIncreasingTime) {
  const auto truth = tilted();
  ImuSamples s = stationary(truth, 0.0, 100.0, 10.0);
  s[500].t = s[499].t;
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, {});
  EXPECT_EQ(r.status, FreeNavStatus::kBadTimestamps);
  EXPECT_EQ(r.samples_used, 500u);
  EXPECT_NE(r.message.find("t = 5"), std::string::npos) << r.message;
  EXPECT_NEAR(r.final_state.t, 5.0, 1e-9);  // stopped at the last good sample
}

TEST(FreeNav, RejectsGapAndNaN) {
  const auto truth = tilted();
  ImuSamples s = stationary(truth, 0.0, 100.0, 10.0);
  ImuSamples gap = s;
  gap.erase(gap.begin() + 300);  // one lost sample: interval doubles
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), gap, {});
  EXPECT_EQ(r.status, FreeNavStatus::kGap);
  EXPECT_NE(r.message.find("gap before t = 3.02"), std::string::npos) << r.message;
  s[42].dtheta.y() = std::numeric_limits<double>::infinity();
  const FreeNavResult r2 = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, {});
  EXPECT_EQ(r2.status, FreeNavStatus::kNonFinite);
  EXPECT_EQ(r2.samples_used, 42u);
}

// The online policy: a gap is bridged (rates held), counted, and navigation goes on. For a
// static IMU holding the rates is exact, so the solution stays at rest.
TEST(FreeNav, BridgesGapWhenAsked) {
  const auto truth = tilted();
  ImuSamples s = stationary(truth, 0.0, 100.0, 20.0);
  s.erase(s.begin() + 700, s.begin() + 750);  // 0.5 s lost
  FreeNavOptions opt;
  opt.gap_policy = GapPolicy::kBridge;
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, opt);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.gaps_bridged, 1u);
  EXPECT_EQ(r.samples_used, s.size());
  EXPECT_NEAR(r.final_state.t, 20.0, 1e-9);
  EXPECT_LT(std::hypot(r.series.back().d_E_m, r.series.back().d_N_m), 1e-6);
  EXPECT_LT(test::attitudeErrorRad(r.final_state.q_BtoL, Quat(truth.C_LB)), 1e-10);
  // The same data with the default policy stops at the gap.
  const FreeNavResult stop = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, {});
  EXPECT_EQ(stop.status, FreeNavStatus::kGap);
  EXPECT_EQ(stop.samples_used, 700u);
}

// Time-stamp jitter of +-10 % (as in real recordings) is not a gap.
TEST(FreeNav, ToleratesTimestampJitter) {
  const auto truth = tilted();
  ImuSamples s;
  double t = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double dt = 0.01 * (1.0 + 0.1 * std::sin(0.7 * k));
    t += dt;
    s.push_back(truth.sample(t, dt));
  }
  const FreeNavResult r = navigateFree(stationaryState(0.0, Quat(truth.C_LB), kSite), s, {});
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LT(std::hypot(r.series.back().d_E_m, r.series.back().d_N_m), 1e-6);
}

TEST(FreeNav, RejectsBadOptionsAndInitialState) {
  FreeNavOptions opt;
  opt.output_interval_s = 0.0;
  std::string why;
  EXPECT_FALSE(opt.IsValid(&why));
  const ImuSamples s = stationary(tilted(), 0.0, 100.0, 1.0);
  EXPECT_EQ(navigateFree(stationaryState(0.0, Quat::Identity(), kSite), s, opt).status,
            FreeNavStatus::kInvalidOptions);
  NavState bad = stationaryState(0.0, Quat::Identity(), kSite);
  bad.lat_rad = 2.0;  // > 90 deg
  EXPECT_EQ(navigateFree(bad, s, {}).status, FreeNavStatus::kBadInitialState);
  bad = stationaryState(std::nan(""), Quat::Identity(), kSite);
  FreeNavigator nav(bad, {});
  EXPECT_EQ(nav.feed(s[0]).status, FreeNavStatus::kBadInitialState);
}

TEST(FreeNav, FirstIntervalStart) {
  ImuSamples s(2);
  s[0].t = 10.0;
  s[1].t = 10.01;
  EXPECT_NEAR(firstIntervalStart(s), 9.99, 1e-12);
  EXPECT_TRUE(std::isnan(firstIntervalStart(ImuSamples(1))));
}

}  // namespace
}  // namespace imubench::nav
