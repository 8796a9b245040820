// Static detection, recording checks and the scalar calibration on synthetic hand sessions
// with a known truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "calib/scalar/scalar_calibration.h"
#include "calib/scalar/scalar_consistency.h"
#include "calib/static_detection.h"
#include "nav/earth.h"

namespace imubench::calib {
namespace {

Mat3 eq1M(const Misalignment& m) {
  Mat3 M;
  M << 1.0, m.xy, -m.xz, -m.yx, 1.0, m.yz, m.zx, -m.zy, 1.0;
  return M;
}

Vec3 reading(const TriadModel& t, const Vec3& input) {
  return t.scale.cwiseProduct(eq1M(t.mis) * input - t.bias);
}

struct Session {
  RawImuData data;
  int poses = 0;
};

// What a real session adds: the Earth rate (in L = ENU, the attitude's reference) and a gyro
// bias that drifts linearly through the session (reading units per second).
struct SessionWorld {
  Vec3 w_ie_L = Vec3::Zero();
  Vec3 gyro_bias_drift = Vec3::Zero();
};

// Hand session: `poses` random attitudes held `hold_s` (the first one `first_hold_s`),
// joined by constant-rate rotations of `turn_s`. Readings at 100 Hz.
Session makeSession(const SensorModel& s, int poses, double first_hold_s, double hold_s,
                    double turn_s, double accel_noise, double gyro_noise, unsigned seed,
                    const SessionWorld& world = {}) {
  const double dt = 0.01, g = 9.81;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Session out;
  out.poses = poses;
  Quat q = Quat::Identity();  // q_BtoL
  double t = 0.0;
  auto emit = [&](const Quat& att, const Vec3& w_B) {
    t += dt;
    const Vec3 f_B = att.conjugate() * Vec3(0.0, 0.0, g);
    const Vec3 na(n01(rng), n01(rng), n01(rng)), ng(n01(rng), n01(rng), n01(rng));
    out.data.t.push_back(t);
    out.data.accel.push_back(reading(s.accel, f_B) + accel_noise * na);
    out.data.gyro.push_back(reading(s.gyro, w_B + att.conjugate() * world.w_ie_L) +
                            gyro_noise * ng + world.gyro_bias_drift * t);
  };
  for (int k = 0; k < poses; ++k) {
    const int n_hold = static_cast<int>(std::lround((k == 0 ? first_hold_s : hold_s) / dt));
    for (int i = 0; i < n_hold; ++i) emit(q, Vec3::Zero());
    if (k + 1 == poses) break;
    Vec3 phi(u(rng), u(rng), u(rng));
    phi = phi.normalized() * (1.0 + 1.5 * std::abs(u(rng)));  // 57..143 deg turns
    const int n_turn = static_cast<int>(std::lround(turn_s / dt));
    const Vec3 w = phi / (n_turn * dt);
    const Quat dq = quatFromRotationVector(w * dt);
    for (int i = 0; i < n_turn; ++i) {
      q = (q * dq).normalized();
      emit(q, w);
    }
  }
  return out;
}

SensorModel truthModel() {
  SensorModel s;
  s.accel.scale = Vec3(1.02, 0.97, 1.01);
  s.accel.bias = Vec3(0.12, -0.08, 0.2);
  s.accel.mis = {2e-3, -1.5e-3, 0.0, 3e-3, 0.0, 0.0};  // frame fixed to the accelerometers
  s.gyro.scale = Vec3(57.0, 58.5, 56.2);               // "deg/s"-like reading units
  s.gyro.bias = Vec3(0.01, -0.02, 0.005);
  s.gyro.mis = {1e-3, -2e-3, 1.5e-3, -1e-3, 2.5e-3, 0.5e-3};
  return s;
}

TEST(StaticDetection, FindsEveryPoseOfASyntheticSession) {
  const Session s = makeSession(truthModel(), 15, 10.0, 4.0, 2.0, 0.01, 0.05, 7);
  const StaticDetectionResult r = detectStaticSpans(s.data);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(static_cast<int>(r.spans.size()), s.poses);
  EXPECT_NEAR(r.spans.front().t0, 0.01, 0.6);
  EXPECT_GT(r.spans.front().duration(), 9.0);
  for (std::size_t k = 1; k < r.spans.size(); ++k) EXPECT_GT(r.spans[k].duration(), 2.5);
}

// Noise-free readings: every static window has zero variance. Running sums over the whole
// recording turned them into rounding noise (even negative) and no hold was found.
TEST(StaticDetection, FindsEveryPoseOfANoiseFreeSession) {
  const Session s = makeSession(truthModel(), 15, 10.0, 4.0, 2.0, 0.0, 0.0, 7);
  const StaticDetectionResult r = detectStaticSpans(s.data);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(static_cast<int>(r.spans.size()), s.poses);
  for (std::size_t k = 1; k < r.spans.size(); ++k) EXPECT_GT(r.spans[k].duration(), 2.5);
}

// Finely and coarsely quantised readings (raw counts): statics flip between a few values.
TEST(StaticDetection, FindsEveryPoseOfAQuantisedSession) {
  for (const double lsb : {1e-4, 1e-3, 2e-2}) {
    Session s = makeSession(truthModel(), 15, 10.0, 4.0, 2.0, 0.05 * lsb, 0.05 * lsb, 11);
    for (auto* series : {&s.data.accel, &s.data.gyro}) {
      for (Vec3& x : *series) x = (x / lsb).array().round().matrix() * lsb;
    }
    const StaticDetectionResult r = detectStaticSpans(s.data);
    ASSERT_TRUE(r.status.ok) << "lsb " << lsb << ": " << r.status.message;
    EXPECT_EQ(static_cast<int>(r.spans.size()), s.poses) << "lsb " << lsb;
    for (std::size_t k = 1; k < r.spans.size(); ++k) EXPECT_GT(r.spans[k].duration(), 2.5);
  }
}

TEST(RecordingCheck, RefusesNaNWithTheSample) {
  Session s = makeSession(truthModel(), 6, 5.0, 3.0, 1.0, 0.01, 0.05, 1);
  s.data.gyro[123].y() = std::nan("");
  const RecordingCheck c = checkRecording(s.data);
  EXPECT_EQ(c.code, RecordingStatusCode::kNonFinite);
  EXPECT_NE(c.message.find("sample 123"), std::string::npos) << c.message;
}

TEST(RecordingCheck, RefusesMissingSegment) {
  Session s = makeSession(truthModel(), 6, 5.0, 3.0, 1.0, 0.01, 0.05, 1);
  for (std::size_t i = 500; i < s.data.t.size(); ++i) s.data.t[i] += 2.0;
  const RecordingCheck c = checkRecording(s.data);
  EXPECT_EQ(c.code, RecordingStatusCode::kMissingSegment);
  EXPECT_NE(c.message.find("sample 500"), std::string::npos) << c.message;
}

TEST(RecordingCheck, RefusesTimeGoingBack) {
  Session s = makeSession(truthModel(), 6, 5.0, 3.0, 1.0, 0.01, 0.05, 1);
  s.data.t[40] = s.data.t[39];
  EXPECT_EQ(checkRecording(s.data).code, RecordingStatusCode::kTimeNotIncreasing);
}

TEST(RecordingCheck, RefusesSaturatedSamples) {
  Session s = makeSession(truthModel(), 6, 5.0, 3.0, 1.0, 0.01, 0.05, 1);
  RecordingCheckOptions o;
  o.accel_min = -150.0;
  o.accel_max = 150.0;
  EXPECT_TRUE(checkRecording(s.data, o).ok);
  s.data.accel[777].x() = 150.0;
  const RecordingCheck c = checkRecording(s.data, o);
  EXPECT_EQ(c.code, RecordingStatusCode::kSaturated);
  EXPECT_NE(c.message.find("accel axis x"), std::string::npos) << c.message;
}

TEST(ScalarCalibration, RefusesTooShortInitialStatic) {
  const Session s = makeSession(truthModel(), 15, 3.0, 4.0, 2.0, 0.01, 0.05, 3);
  ScalarCalibrationOptions o;
  o.min_initial_static_s = 8.0;
  const ScalarCalibrationResult r = scalarCalibrate(s.data, o, true);
  EXPECT_EQ(r.status.code, RecordingStatusCode::kTooShortStatic) << r.status.message;
}

TEST(ScalarCalibration, RefusesTooFewStatics) {
  const Session s = makeSession(truthModel(), 4, 10.0, 4.0, 2.0, 0.01, 0.05, 3);
  const ScalarCalibrationResult r = scalarCalibrate(s.data, {}, true);
  EXPECT_EQ(r.status.code, RecordingStatusCode::kTooFewStatics) << r.status.message;
}

TEST(ScalarCalibration, RecoversTruthOfASyntheticSession) {
  const SensorModel truth = truthModel();
  const Session s = makeSession(truth, 30, 20.0, 4.0, 2.0, 0.003, 0.02, 11);
  ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  const ScalarCalibrationResult r = scalarCalibrate(s.data, o, true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(static_cast<int>(r.spans.size()), 30);
  const TriadModel& a = r.accel();
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.scale[k], truth.accel.scale[k], 2e-4) << k;
    EXPECT_NEAR(a.bias[k], truth.accel.bias[k], 2e-3) << k;
  }
  EXPECT_NEAR(a.mis.xy, truth.accel.mis.xy, 2e-4);
  EXPECT_NEAR(a.mis.xz, truth.accel.mis.xz, 2e-4);
  EXPECT_NEAR(a.mis.yz, truth.accel.mis.yz, 2e-4);
  EXPECT_LT(r.accel_rms_after, 0.2 * r.accel_rms_before);
  EXPECT_FALSE(r.report.uncertainty.at("accel.misalignment.zy").observable);
  const TriadModel& g = r.gyro();
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(g.scale[k] / truth.gyro.scale[k], 1.0, 3e-3) << k;
    EXPECT_NEAR(g.bias[k], truth.gyro.bias[k], 1e-4) << k;
  }
  EXPECT_NEAR(g.mis.xy, truth.gyro.mis.xy, 1e-3);
  EXPECT_NEAR(g.mis.zx, truth.gyro.mis.zx, 1e-3);
  EXPECT_NEAR(g.mis.yz, truth.gyro.mis.yz, 1e-3);
  EXPECT_LT(r.gyro_rms_after, r.gyro_rms_before);
  // Every sigma is finite and small against its value's tolerance.
  EXPECT_GT(r.report.uncertainty.at("accel.scale.x").sigma.value_or(-1.0), 0.0);
}

// A session with the Earth rate at 45 deg and a drifting gyro bias: with the latitude given, the
// vertical Earth rate leaves the bias and every bias error lies within its stated sigma (the
// sigma carries the horizontal Earth rate and the drift); interpolating the bias between poses
// gives better gyro scales than holding the first pose's.
TEST(ScalarCalibration, EarthRateAndBiasDriftAreInTheBiasAndItsSigma) {
  const SensorModel truth = truthModel();
  const double lat = 45.0 * kDegToRad;
  SessionWorld world;
  world.w_ie_L = nav::kEarthRate * Vec3(0.0, std::cos(lat), std::sin(lat));
  world.gyro_bias_drift = Vec3(2e-4, -1.5e-4, 1e-4);  // reading units per s (~ 3 mrad/s drift)
  const Session s = makeSession(truth, 30, 20.0, 4.0, 2.0, 0.003, 0.002, 17, world);
  ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  o.latitude_rad = lat;
  const ScalarCalibrationResult r = scalarCalibrate(s.data, o, true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const TriadModel& g = r.gyro();
  for (int k = 0; k < 3; ++k) {
    const double sigma =
        r.report.uncertainty.at(std::string("gyro.bias.") + "xyz"[k]).sigma.value();
    EXPECT_LT(std::abs(g.bias[k] - truth.gyro.bias[k]), 3.0 * sigma) << k;
  }
  ScalarCalibrationOptions held = o;
  held.interpolate_gyro_bias = false;
  const ScalarCalibrationResult h = scalarCalibrate(s.data, held, true);
  ASSERT_TRUE(h.status.ok) << h.status.message;
  double err_interp = 0.0, err_held = 0.0;
  for (int k = 0; k < 3; ++k) {
    err_interp += std::pow(g.scale[k] / truth.gyro.scale[k] - 1.0, 2);
    err_held += std::pow(h.gyro().scale[k] / truth.gyro.scale[k] - 1.0, 2);
  }
  EXPECT_LT(err_interp, 0.25 * err_held) << std::sqrt(err_interp) << " vs " << std::sqrt(err_held);
  EXPECT_LT(r.gyro_rms_after, h.gyro_rms_after);
}

// Honest sigmas on a session with white noise only: the accelerometer's normalised residual
// RMS is near 1 and the two halves of the session agree within their sigmas (RMS z near 1,
// no |z| beyond 4 over the ~20 coefficients compared). Sigmas 3x too small would give RMS z
// near 3.
// The consistency checks of a session's scalar calibration (printed).
ScalarConsistency consistencyOf(const Session& s) {
  ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  const ScalarCalibrationResult r = scalarCalibrate(s.data, o, true);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  const ScalarConsistency c = scalarConsistency(s.data, r, o, true);
  std::printf("%s", describe(c).c_str());
  return c;
}

TEST(ScalarConsistency, WhiteNoiseSessionHasHonestSigmas) {
  const ScalarConsistency c =
      consistencyOf(makeSession(truthModel(), 40, 20.0, 4.0, 2.0, 0.003, 0.02, 23));
  EXPECT_GT(c.accel_normalised_rms, 0.6);
  EXPECT_LT(c.accel_normalised_rms, 1.5);
  ASSERT_TRUE(c.halves_ok) << c.halves_why;
  EXPECT_GE(c.rows.size(), 18u);
  EXPECT_GT(c.rms_z, 0.4);
  EXPECT_LT(c.rms_z, 1.8);
  EXPECT_LT(c.max_abs_z, 4.0) << c.worst;
}

// The check sees sigmas that are too small: the same session with noise whose per-pose means
// wander (a bias random walk the white-noise sigma does not know) gives a normalised residual
// RMS well above 1.
TEST(ScalarConsistency, CorrelatedNoiseShowsAsNormalisedRmsAboveOne) {
  Session s = makeSession(truthModel(), 40, 20.0, 4.0, 2.0, 0.003, 0.02, 29);
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  Vec3 walk = Vec3::Zero();
  for (Vec3& a : s.data.accel) {
    walk += 2e-4 * Vec3(n01(rng), n01(rng), n01(rng));
    a += walk;
  }
  EXPECT_GT(consistencyOf(s).accel_normalised_rms, 3.0);
}

}  // namespace
}  // namespace imubench::calib

namespace imubench::calib {
namespace {

// Increments at 100 Hz from 0 to 30 s with the samples of (gap_t0, gap_t1) missing.
std::vector<nav::ImuSample> incrementsWithGap(double gap_t0, double gap_t1) {
  std::vector<nav::ImuSample> imu;
  for (int k = 1; k <= 3000; ++k) {
    const double t = 0.01 * k;
    if (t > gap_t0 && t < gap_t1) continue;
    nav::ImuSample s;
    s.t = t;
    s.dvel = Vec3(0.0, 0.0, 9.81 * 0.01);
    imu.push_back(s);
  }
  return imu;
}

Segment segment(double t0, double t1, SegmentKind kind) {
  Segment s;
  s.t0 = t0;
  s.t1 = t1;
  s.kind = kind;
  return s;
}

// A resumed run has a gap where the daemon was down: between a finished hold and the re-run
// step it harms nothing; inside a segment or next to a rotation (whose integration it would
// cut) it is refused, naming the sample; without segments every gap is refused.
TEST(IncrementCheck, GapsAreRefusedOnlyWhereTheyHarmTheSegments) {
  const std::vector<Segment> segs = {
      segment(1.0, 8.0, SegmentKind::kStatic), segment(8.0, 12.0, SegmentKind::kRotate),
      segment(12.0, 18.0, SegmentKind::kStatic), segment(22.0, 29.0, SegmentKind::kStatic)};
  const IncrementCheckOptions o;
  EXPECT_TRUE(checkIncrements(incrementsWithGap(18.5, 21.5), o, "run", segs).ok);
  const RecordingCheck strict = checkIncrements(incrementsWithGap(18.5, 21.5), o, "run");
  EXPECT_EQ(strict.code, RecordingStatusCode::kMissingSegment) << strict.message;
  const RecordingCheck inside = checkIncrements(incrementsWithGap(14.0, 15.0), o, "run", segs);
  EXPECT_EQ(inside.code, RecordingStatusCode::kMissingSegment);
  EXPECT_NE(inside.message.find("run: IMU sample"), std::string::npos) << inside.message;
  // Between the rotation and the next hold there is no unused stretch: 12.0 .. 12.0.
  const std::vector<Segment> loose = {segment(1.0, 8.0, SegmentKind::kStatic),
                                      segment(8.0, 11.0, SegmentKind::kRotate),
                                      segment(13.0, 18.0, SegmentKind::kStatic)};
  EXPECT_EQ(checkIncrements(incrementsWithGap(11.2, 12.8), o, "run", loose).code,
            RecordingStatusCode::kMissingSegment);
}

}  // namespace
}  // namespace imubench::calib
