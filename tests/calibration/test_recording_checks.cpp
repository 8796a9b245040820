// The checks before any calibration (calib/recording_checks.h) and the honest output of the
// scalar path (issue 26, item 4) on the real recordings (read-only) and alterations of them:
// a time axis read at the wrong rate is refused by the gyro scales, the IMU's range is
// honoured whatever the reading unit, noise-free data are said, the motion a session holds is
// counted, and a truth file's extra effects are compared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "calib/noise.h"
#include "calib/recording_checks.h"
#include "calib/scalar/scalar_calibration.h"
#include "calib/scalar/scalar_consistency.h"
#include "calib/truth_comparison.h"
#include "io/import_real.h"

namespace imubench {
namespace {

const std::string kDir = IMUBENCH_REAL_DATA_DIR;

calib::ScalarCalibrationOptions options() {
  calib::ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  return o;
}

io::RealImport mpuLog(double rate_hz = io::kSixColumnLogRateHz) {
  io::RealImport in = io::readSixColumnLog(kDir + "/mikoff_mpu9150_imu0.log", rate_hz);
  EXPECT_TRUE(in.status.ok) << in.status.message;
  return in;
}

TEST(RecordingChecks, RightRateIsConsistent) {
  const io::RealImport in = mpuLog();
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, options(), true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const calib::RateConsistency c = calib::checkRateConsistency(
      r.gyro(), *calib::gyroReadingsPerRadps(in.gyro_unit), "--rate 100 Hz");
  EXPECT_TRUE(c.judged);
  EXPECT_TRUE(c.status.ok) << c.status.message;
}

// The 100 Hz log read at 50 Hz: every rotation takes twice as long, the gyro scales come out
// at 2 readings per rad/s for a rad/s gyro: refused, naming the option.
TEST(RecordingChecks, HalfTheRateIsRefused) {
  const io::RealImport in = mpuLog(50.0);
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, options(), true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const calib::RateConsistency c = calib::checkRateConsistency(
      r.gyro(), *calib::gyroReadingsPerRadps(in.gyro_unit), "--rate 50 Hz");
  ASSERT_FALSE(c.status.ok);
  EXPECT_NEAR(c.factor, 2.0, 0.1);
  EXPECT_NE(c.status.message.find("--rate 50 Hz"), std::string::npos) << c.status.message;
}

// The MPU log turns faster than 100 deg/s: with that range given, its samples are clipped.
TEST(RecordingChecks, GyroRangeIsHonouredOnReadings) {
  const io::RealImport in = mpuLog();
  calib::ScalarCalibrationOptions o = options();
  o.gyro_range_radps = 100.0 * kDegToRad;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, true);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.code, calib::RecordingStatusCode::kSaturated);
  EXPECT_NE(r.status.message.find("range"), std::string::npos) << r.status.message;
  o.gyro_range_radps = 2000.0 * kDegToRad;  // the MPU-9150's largest range
  EXPECT_TRUE(calib::scalarCalibrate(in.data, o, true).status.ok);
}

TEST(RecordingChecks, AccelRangeIsHonouredOnReadings) {
  const io::RealImport in = mpuLog();
  calib::ScalarCalibrationOptions o = options();
  o.accel_range_mps2 = 0.5 * 9.80665;  // half a g: every face reaches it
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, true);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.code, calib::RecordingStatusCode::kSaturated);
}

// Noise-free data (every static reading replaced by the pose's mean): no normalised figure.
TEST(RecordingChecks, NoiseFreeScalarConsistencyIsSaid) {
  const io::RealImport in = mpuLog();
  const calib::ScalarCalibrationOptions o = options();
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  calib::RawImuData d = in.data;
  for (const calib::StaticSpan& s : r.spans) {
    const Vec3 m = calib::spanMean(d.accel, s);
    for (std::size_t i = s.begin; i < s.end; ++i) d.accel[i] = m;
  }
  const calib::ScalarConsistency c = calib::scalarConsistency(d, r, o, true);
  EXPECT_TRUE(c.resolution_limited);
  EXPECT_TRUE(std::isnan(c.accel_normalised_rms));
  EXPECT_NE(calib::describe(c).find("not meaningful"), std::string::npos) << calib::describe(c);
  const calib::ScalarConsistency real = calib::scalarConsistency(in.data, r, o, true);
  EXPECT_FALSE(real.resolution_limited);
  EXPECT_TRUE(std::isfinite(real.accel_normalised_rms));
}

TEST(RecordingChecks, MotionSupportOfAHandSession) {
  const io::RealImport in = mpuLog();
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, options(), true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const calib::MotionSupport m = calib::motionSupport(in.data, r.spans);
  std::cout << m.describe() << "\n";
  EXPECT_GE(m.attitudes.size(), 6u);
  EXPECT_TRUE(m.determinesTriads()) << m.missing();
  // One pose only: one attitude, nothing determined.
  const calib::MotionSupport one =
      calib::motionSupport(in.data, std::span<const calib::StaticSpan>(r.spans.data(), 1));
  EXPECT_EQ(one.attitudes.size(), 1u);
  EXPECT_FALSE(one.determinesTriads());
}

TEST(RecordingChecks, CountDistinct) {
  EXPECT_EQ(calib::countDistinct({1.0, 1.0, 1.0 + 1e-12, 1.0}, 1e-9), 1);
  EXPECT_EQ(calib::countDistinct({0.0, 0.061, 0.0, -0.061}, 1e-9), 3);
  EXPECT_EQ(calib::countDistinct({}, 1e-9), 0);
}

// The counting sorts with a radix sort of the doubles' bits: the same count as sorting with
// std::sort, on readings of both signs around zero (sign and exponent vary), around g (they do
// not), quantised ones, -0.0 beside +0.0, and the tolerance's edge.
TEST(RecordingChecks, CountDistinctMatchesComparisonSort) {
  auto reference = [](std::vector<double> v, double tol) {
    std::sort(v.begin(), v.end());
    int n = v.empty() ? 0 : 1;
    for (std::size_t i = 1; i < v.size(); ++i) n += v[i] - v[i - 1] > tol ? 1 : 0;
    return n;
  };
  calib::GaussianSource g(5);
  std::vector<std::vector<double>> sets(4);
  for (int i = 0; i < 20000; ++i) {
    sets[0].push_back(1e-5 * g.next());                     // gyro noise about zero
    sets[1].push_back(9.81 + 2e-4 * g.next());              // accelerometer along g
    sets[2].push_back(0.061 * std::round(3.0 * g.next()));  // quantised, both signs
    sets[3].push_back(i % 3 == 0 ? -0.0 : (i % 3 == 1 ? 0.0 : 1e-9 * (i % 7)));
  }
  for (const auto& v : sets) {
    for (double tol : {0.0, 1e-12, 1e-9, 1e-6}) {
      EXPECT_EQ(calib::countDistinct(v, tol), reference(v, tol)) << "tolerance " << tol;
    }
  }
}

// A truth with a lever arm: compared even though the estimate does not model it (shown, not
// judged), and judged against 2 sigma when the estimate carries it.
TEST(TruthComparisonExtra, TruthExtraEffectsAreCompared) {
  calib::BenchTruth truth;
  truth.extra.enable(calib::EffectId::kLeverArm);
  truth.extra.lever_arm->r_m = Vec3(0.05, -0.03, 0.02);
  calib::CoefficientReport est;
  calib::TruthComparison c = calib::compareWithTruth(est, truth);
  int rows = 0;
  for (const calib::ComparisonRow& r : c.rows) {
    if (r.name.rfind("extra.lever_arm.", 0) != 0) continue;
    ++rows;
    EXPECT_FALSE(r.modelled);
    EXPECT_FALSE(r.observable);
  }
  EXPECT_EQ(rows, 3);
  EXPECT_EQ(c.unmodelled, 3);
  est.values.extra = truth.extra;
  est.values.extra.lever_arm->r_m.x() += 0.01;
  for (const char* a : {"x", "y", "z"}) {
    est.setSigma(std::string("extra.lever_arm.r_m.") + a, 0.001);
  }
  c = calib::compareWithTruth(est, truth);
  EXPECT_EQ(c.unmodelled, 0);
  EXPECT_EQ(c.judged, 3);
  EXPECT_EQ(c.outside, 1);  // x is 10 sigma off
}

}  // namespace
}  // namespace imubench
