// insMech: exactness on closed-form trajectories, stationary long run, coning compensation.
#include "nav/strapdown.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nav/free_navigation.h"
#include "tests/nav/nav_truth.h"

namespace imubench::nav {
namespace {

using test::attitudeErrorRad;

constexpr double kLat58 = 58.0 * kDegToRad;

// A non-trivial attitude so that every body axis sees gravity and Earth rate.
Mat3 tiltedAttitude() {
  return Rz(37.0 * kDegToRad) * Rx(-12.0 * kDegToRad) * Ry(25.0 * kDegToRad);
}

TEST(MechOptions, DefaultsValidAndBadGravityRejected) {
  MechOptions opt;
  std::string why;
  EXPECT_TRUE(opt.IsValid(&why)) << why;
  EXPECT_TRUE(opt.coning_compensation);
  EXPECT_TRUE(opt.sculling_compensation);
  EXPECT_EQ(opt.vertical, VerticalChannel::kHoldHeight);
  opt.gravity_mps2 = 0.0;
  EXPECT_FALSE(opt.IsValid(&why));
  EXPECT_NE(why.find("gravity"), std::string::npos);
}

// Stationary, error-free IMU at 58 N, 100 m: 2 h at 100 Hz must stay put (< 1 m).
TEST(InsMech, StationaryTwoHoursStaysWithinOneMetre) {
  test::StationaryTruth truth;
  truth.C_LB = tiltedAttitude();
  truth.lat_rad = kLat58;
  truth.height_m = 100.0;
  const double rate = 100.0;
  const double dt = 1.0 / rate;
  const long n = static_cast<long>(2.0 * 3600.0 * rate);

  NavState s;
  s.q_BtoL = Quat(truth.C_LB);
  s.lat_rad = truth.lat_rad;
  s.lon_rad = 0.3;
  s.height_m = truth.height_m;
  const NavState s0 = s;
  const Radii r = radiiOfCurvature(kLat58);
  MechOptions opt;
  ImuSample prev;
  prev.t = 0.0;
  double max_horiz = 0.0;
  for (long k = 1; k <= n; ++k) {
    const ImuSample cur = truth.sample(static_cast<double>(k) * dt, dt);
    s = insMech(s, prev, cur, opt);
    prev = cur;
    const double dN = (s.lat_rad - s0.lat_rad) * (r.meridian + 100.0);
    const double dE = (s.lon_rad - s0.lon_rad) * (r.prime_vertical + 100.0) * std::cos(kLat58);
    max_horiz = std::max(max_horiz, std::hypot(dE, dN));
  }
  RecordProperty("max_horizontal_error_m", test::fmt(max_horiz));
  EXPECT_LT(max_horiz, 1.0);
  EXPECT_LT(s.v_L.norm(), 1e-3);
  EXPECT_LT(attitudeErrorRad(s.q_BtoL, s0.q_BtoL), 1e-9);
  EXPECT_NEAR(s.t, 7200.0, 1e-6);
  EXPECT_EQ(s.height_m, 100.0);
}

// A stationary IMU whose velocity increments miss gravity by a fraction must drift:
// guards against a mechanization that ignores the measured increments.
TEST(InsMech, AccelBiasMovesTheSolution) {
  test::StationaryTruth truth;
  truth.lat_rad = kLat58;
  truth.accel_bias_B = Vec3(1e-3, 0.0, 0.0);  // 1e-3 m/s^2 East (body = ENU)
  NavState s;
  s.lat_rad = kLat58;
  MechOptions opt;
  ImuSample prev;
  for (int k = 1; k <= 1000; ++k) {
    const ImuSample cur = truth.sample(k * 0.01, 0.01);
    s = insMech(s, prev, cur, opt);
    prev = cur;
  }
  // 10 s: v_E ~ b t (Schuler and Coriolis negligible over 10 s).
  EXPECT_NEAR(s.v_L.x(), 1e-2, 1e-5);
  EXPECT_NEAR(s.v_L.y(), 0.0, 1e-5);
}

// Rotation about a fixed (Earth-fixed) axis at constant rate, with Earth rate in the gyros
// and gravity in the accelerometers: a 180-degree turn at 20 deg/s must integrate to the
// exact attitude (sub-milliarcsecond) and keep the velocity near zero.
struct TurnCase {
  double rate_hz;
  Vec3 axis_L;
  double max_att_err_arcsec;
  double max_vel_err_mps;
};

class FixedAxisTurn : public ::testing::TestWithParam<TurnCase> {};

TEST_P(FixedAxisTurn, IntegratesExactly) {
  const TurnCase c = GetParam();
  test::FixedAxisTurnTruth truth;
  truth.C0 = tiltedAttitude();
  truth.u_L = c.axis_L.normalized();
  truth.rate = 20.0 * kDegToRad;
  truth.lat_rad = kLat58;
  truth.height_m = 100.0;
  const double dt = 1.0 / c.rate_hz;
  const int n = static_cast<int>(std::lround(9.0 * c.rate_hz));  // 180 deg

  NavState s;
  s.q_BtoL = Quat(truth.C0);
  s.lat_rad = truth.lat_rad;
  s.height_m = truth.height_m;
  MechOptions opt;
  ImuSample prev;
  double worst_att = 0.0;
  double worst_vel = 0.0;
  for (int k = 1; k <= n; ++k) {
    const ImuSample cur = truth.sample(k * dt, dt);
    s = insMech(s, prev, cur, opt);
    prev = cur;
    worst_att = std::max(worst_att, attitudeErrorRad(s.q_BtoL, Quat(truth.C_LB(k * dt))));
    worst_vel = std::max(worst_vel, s.v_L.norm());
  }
  // The turn really happened: the attitude moved by 180 degrees.
  EXPECT_NEAR(attitudeErrorRad(s.q_BtoL, Quat(truth.C0)), kPi, 1e-6);
  RecordProperty("worst_att_err_arcsec", test::fmt(worst_att * kRadToArcsec));
  RecordProperty("worst_vel_err_mps", test::fmt(worst_vel));
  EXPECT_LT(worst_att * kRadToArcsec, c.max_att_err_arcsec);
  EXPECT_LT(worst_vel, c.max_vel_err_mps);
}

INSTANTIATE_TEST_SUITE_P(
    Axes, FixedAxisTurn,
    ::testing::Values(TurnCase{100.0, Vec3::UnitX(), 1e-3, 1e-6},
                      TurnCase{100.0, Vec3::UnitY(), 1e-3, 1e-6},
                      TurnCase{2000.0, Vec3(1.0, -1.0, 0.0), 1e-3, 1e-8},
                      // 10 Hz: 2 degrees per sample; attitude still sub-arcsecond, the
                      // velocity error is third order in the per-sample angle.
                      TurnCase{10.0, Vec3(0.3, 1.0, 0.2), 1e-1, 2e-4}),
    [](const ::testing::TestParamInfo<TurnCase>& param_info) {
      return std::to_string(static_cast<int>(param_info.param.rate_hz)) + "Hz_axis" +
             std::to_string(param_info.index);
    });

// The same turn at 20 Hz: sculling + second-order rotation compensation cut the velocity
// error by orders of magnitude against the first-order update (guards both terms).
double turnVelocityError(bool sculling) {
  test::FixedAxisTurnTruth truth;
  truth.C0 = tiltedAttitude();
  truth.u_L = Vec3(0.3, 1.0, 0.2).normalized();
  truth.rate = 20.0 * kDegToRad;
  truth.lat_rad = kLat58;
  const double dt = 1.0 / 20.0;
  NavState s;
  s.q_BtoL = Quat(truth.C0);
  s.lat_rad = truth.lat_rad;
  MechOptions opt;
  opt.sculling_compensation = sculling;
  ImuSample prev;
  double worst = 0.0;
  for (int k = 1; k <= 180; ++k) {
    const ImuSample cur = truth.sample(k * dt, dt);
    s = insMech(s, prev, cur, opt);
    prev = cur;
    worst = std::max(worst, s.v_L.norm());
  }
  return worst;
}

TEST(InsMech, ScullingCutsTurnVelocityError) {
  const double with = turnVelocityError(true);
  const double without = turnVelocityError(false);
  RecordProperty("turn_vel_err_with_sculling", test::fmt(with));
  RecordProperty("turn_vel_err_without_sculling", test::fmt(without));
  EXPECT_GT(without, 50.0 * with);
}

// Classical coning at 2 deg half-angle, 2 Hz, sampled at 200 Hz for 10 s: the two-sample
// coning correction must cut the attitude error at least tenfold.
double coningError(bool compensate, double* uncompensated_drift_model = nullptr) {
  const test::ConingTruth truth{2.0 * kDegToRad, 2.0 * kPi * 2.0};
  const double lat = kLat58;
  const Vec3 w_ie_L = earthRateL(lat);
  const Quat q_ItoL0(Rz(0.4) * Rx(0.2));
  auto q_true = [&](double t) {
    return quatFromRotationVector(-w_ie_L * t) * q_ItoL0 * truth.q_BtoI(t);
  };
  const double rate = 200.0;
  const double dt = 1.0 / rate;
  const int n = static_cast<int>(10.0 * rate);
  NavState s;
  s.q_BtoL = q_true(0.0);
  s.lat_rad = lat;
  MechOptions opt;
  opt.coning_compensation = compensate;
  ImuSample prev;
  for (int k = 1; k <= n; ++k) {
    ImuSample cur;
    cur.t = k * dt;
    cur.dtheta = truth.dtheta(cur.t - dt, cur.t);
    // dvel stays zero: only the attitude is examined; in hold-height mode the velocity
    // then stays exactly zero, so the transport rate cannot disturb the attitude.
    s = insMech(s, prev, cur, opt);
    prev = cur;
  }
  if (uncompensated_drift_model) {
    // Classical pseudo-coning drift of the uncompensated (single-sample) update, about the
    // coning axis: W sin^2(a) / 2 * (1 - sin(W dt) / (W dt)) rad/s (e.g. Savage 1998).
    const double wdt = truth.freq * dt;
    *uncompensated_drift_model = 0.5 * truth.freq * std::pow(std::sin(truth.half_angle), 2) *
                                 (1.0 - std::sin(wdt) / wdt) * (n * dt);
  }
  return attitudeErrorRad(s.q_BtoL, q_true(n * dt));
}

TEST(ConingTruthModel, RateMatchesQuaternionDerivative) {
  const test::ConingTruth truth{3.0 * kDegToRad, 5.0};
  for (double t : {0.0, 0.37, 1.9}) {
    const double h = 1e-6;
    const Quat q = truth.q_BtoI(t);
    const Quat qd((truth.q_BtoI(t + h).coeffs() - truth.q_BtoI(t - h).coeffs()) / (2.0 * h));
    const Quat w = q.conjugate() * qd;  // 0.5 (0, w_B)
    EXPECT_NEAR(2.0 * w.x(), truth.rate_B(t).x(), 1e-8);
    EXPECT_NEAR(2.0 * w.y(), truth.rate_B(t).y(), 1e-8);
    EXPECT_NEAR(2.0 * w.z(), truth.rate_B(t).z(), 1e-8);
  }
}

TEST(InsMech, ConingCompensationCutsErrorTenfold) {
  double drift_model = 0.0;
  const double without = coningError(false, &drift_model);
  const double with = coningError(true);
  RecordProperty("coning_err_without_arcsec", test::fmt(without * kRadToArcsec));
  RecordProperty("coning_err_with_arcsec", test::fmt(with * kRadToArcsec));
  EXPECT_GT(without, 10.0 * with);
  // The uncompensated error is the classical coning drift (within 5 %): the truth model
  // really cones, and nothing else is wrong.
  EXPECT_NEAR(without, drift_model, 0.05 * drift_model);
}

TEST(InsMech, FreeVerticalChannelFallsWithoutLift) {
  // With zero increments and a free vertical channel the IMU is in free fall: v_U = -g t.
  NavState s;
  s.lat_rad = kLat58;
  s.height_m = 100.0;
  MechOptions opt;
  opt.vertical = VerticalChannel::kFree;
  opt.gravity_mps2 = 9.8;
  ImuSample prev;
  for (int k = 1; k <= 100; ++k) {
    ImuSample cur;
    cur.t = k * 0.01;
    s = insMech(s, prev, cur, opt);
    prev = cur;
  }
  EXPECT_NEAR(s.v_L.z(), -9.8, 1e-6);
  EXPECT_NEAR(s.height_m, 100.0 - 0.5 * 9.8, 1e-3);
}

}  // namespace
}  // namespace imubench::nav

namespace imubench::nav {
namespace {

// A measured site gravity (recording's gravity_mps2) reaches the mechanization through
// mechOptionsForSite: with a free vertical channel, increments made with that gravity keep
// v_U at zero only when the override is used.
TEST(InsMech, SiteGravityOverrideIsUsed) {
  const Site site{kLat58, 100.0, 9.8200};  // differs from normal gravity by ~2 mm/s^2
  const double g_normal = normalGravity(kLat58, 100.0);
  ASSERT_GT(std::abs(9.82 - g_normal), 1e-3);
  auto run = [&](const MechOptions& opt) {
    NavState s = stationaryState(0.0, Quat::Identity(), site);
    ImuSample prev;
    for (int k = 1; k <= 100; ++k) {
      ImuSample cur;
      cur.t = k * 0.01;
      cur.dtheta = earthRateL(kLat58) * 0.01;
      cur.dvel = Vec3(0.0, 0.0, 9.82) * 0.01;
      s = insMech(s, prev, cur, opt);
      prev = cur;
    }
    return s.v_L.z();
  };
  MechOptions with = mechOptionsForSite(site);
  with.vertical = VerticalChannel::kFree;
  MechOptions without;
  without.vertical = VerticalChannel::kFree;
  EXPECT_NEAR(run(with), 0.0, 1e-9);
  EXPECT_NEAR(run(without), 9.82 - g_normal, 1e-6);
}

}  // namespace
}  // namespace imubench::nav
