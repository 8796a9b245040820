// Direct calibration on simulated bundled plans: exact recovery on a perfect table, sigmas
// that cover the noise, refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "calib/direct_calibration.h"
#include "test_direct_sim.h"

namespace imubench::calib {
namespace {

using testing::exampleSensors;
using testing::libraryMotion;
using testing::simulateDirect;

double misDiff(const Misalignment& a, const Misalignment& b) {
  return std::max({std::abs(a.xy - b.xy), std::abs(a.xz - b.xz), std::abs(a.yx - b.yx),
                   std::abs(a.yz - b.yz), std::abs(a.zx - b.zx), std::abs(a.zy - b.zy)});
}

class DirectPlans : public ::testing::TestWithParam<std::string> {};

TEST_P(DirectPlans, RecoversTruthOnAPerfectTable) {
  const SensorModel truth = exampleSensors();
  const DirectCalibrationInput in = simulateDirect(libraryMotion(GetParam()), truth, {});
  const DirectCalibrationResult r = calibrateDirect(in);
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  EXPECT_GE(r.statics_used, 12);
  EXPECT_GE(r.rotations_used, 6);
  const SensorModel& est = r.report.values.sensors;
  EXPECT_LT((est.accel.scale - truth.accel.scale).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((est.accel.bias - truth.accel.bias).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT(misDiff(est.accel.mis, truth.accel.mis), 1e-9);
  // Gyro scales to round-off: a rate run's angle is read from encoder samples at rest on
  // either side of the run. (It used to be interpolated linearly between the 20 Hz encoder
  // samples at the IMU window's ends, which bracket the start/end of the 10 deg/s^2 ramps:
  // that lost ~3e-5 rad of the 6*pi turned and left a +0.4e-6..+1.7e-6 scale per axis,
  // depending on where the samples fell relative to the ramps.)
  EXPECT_LT((est.gyro.scale - truth.gyro.scale).cwiseAbs().maxCoeff(), 1e-12)
      << (est.gyro.scale - truth.gyro.scale).transpose() << " | bias "
      << (est.gyro.bias - truth.gyro.bias).transpose() << " | rms " << r.gyro_residual_rms;
  EXPECT_LT((est.gyro.bias - truth.gyro.bias).cwiseAbs().maxCoeff(), 1e-14);
  // Gyro misalignments to 1e-10: the rate runs' Earth-rate input follows the turn as the gyros
  // integrate it, which carries their bias along the axis (2e-6 rad/s: ~6e-11 rad here).
  EXPECT_LT(misDiff(est.gyro.mis, truth.gyro.mis), 1e-10);
  EXPECT_LT(r.accel_residual_rms, 1e-8);
  EXPECT_LT(r.gyro_residual_rms, 1e-10);
  for (const auto& [name, u] : r.report.uncertainty)
    EXPECT_TRUE(u.observable) << name << " flagged unobservable by a full direct plan";
}

TEST_P(DirectPlans, ErrorsStayWithinTheirSigmasUnderNoise) {
  const SensorModel truth = exampleSensors();
  // Tactical-grade white noise; bias instability off: a drifting bias is not scatter the
  // residuals can see (it is a model error, reported by the explain/validation tools).
  NoiseModel noise = NoiseModel::tactical();
  noise.accel.bias_sigma = 0.0;
  noise.gyro.bias_sigma = 0.0;
  const DirectCalibrationInput in = simulateDirect(libraryMotion(GetParam()), truth, {}, noise);
  const DirectCalibrationResult r = calibrateDirect(in);
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  const std::vector<std::string> names = flatNames(r.report.values);
  const std::vector<double> est = flatValues(r.report.values);
  BenchTruth t;
  t.sensors = truth;
  t.table_kind = r.report.values.table_kind;
  const std::vector<double> tv = flatValues(t);
  int checked = 0;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k].rfind("table.", 0) == 0) continue;
    const auto it = r.report.uncertainty.find(names[k]);
    ASSERT_NE(it, r.report.uncertainty.end()) << names[k];
    ASSERT_TRUE(it->second.sigma.has_value()) << names[k];
    const double sigma = *it->second.sigma;
    EXPECT_GT(sigma, 0.0) << names[k];
    EXPECT_LT(std::abs(est[k] - tv[k]), 5.0 * sigma) << names[k] << " sigma " << sigma;
    ++checked;
  }
  EXPECT_EQ(checked, 24);
}

// The sigmas of scales and biases are the sensor noise propagated through the axis-pair
// estimator, not the residual scatter (which on a tilted table also holds the tilt's misfit of
// the accelerometer rows and inflated the accelerometer sigmas tenfold): over 8 noisy benches
// on a tilted table, the z-scores of the 12 scales and biases are standard normal (mean square
// within 0.5..1.7, at least 85 % inside 2 sigma). Mounting and nonorthogonality are left out
// here: with misalignments of ~1e-3 they shift the gyro scales deterministically by their
// product (~3e-7, second order; the seed's finding holds to first order), which is a bias of
// the method, not noise.
TEST_P(DirectPlans, ScaleAndBiasSigmasAreHonestOnATiltedTable) {
  const SensorModel truth = exampleSensors();
  TableErrors table;
  table.base_tilt = Vec2(40, -25) * kArcsecToRad;
  BenchTruth t;
  t.sensors = truth;
  std::vector<double> z;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const DirectCalibrationInput in = simulateDirect(
        libraryMotion(GetParam()), truth, table, NoiseModel::navigationGrade(), 50.0, 20.0, seed);
    const DirectCalibrationResult r = calibrateDirect(in);
    ASSERT_TRUE(r.status.HasResult()) << r.status.message;
    t.table_kind = r.report.values.table_kind;
    for (const char* triad : {"accel", "gyro"}) {
      for (const char* q : {"scale", "bias"}) {
        for (const char* ax : {"x", "y", "z"}) {
          const std::string n = std::string(triad) + "." + q + "." + ax;
          const double sigma = r.report.uncertainty.at(n).sigma.value_or(0.0);
          ASSERT_GT(sigma, 0.0) << n;
          z.push_back((*flatValue(r.report.values, n) - *flatValue(t, n)) / sigma);
        }
      }
    }
  }
  double sum_sq = 0.0;
  int within = 0;
  for (double v : z) {
    sum_sq += v * v;
    within += std::abs(v) <= 2.0 ? 1 : 0;
  }
  const double mean_sq = sum_sq / static_cast<double>(z.size());
  EXPECT_GT(mean_sq, 0.5) << "sigmas inflated";
  EXPECT_LT(mean_sq, 1.7) << "sigmas too small";
  EXPECT_GE(within, static_cast<int>(0.85 * static_cast<double>(z.size())));
}

INSTANTIATE_TEST_SUITE_P(Bundled, DirectPlans,
                         ::testing::Values("direct_two_axis", "direct_three_axis"));

TEST(DirectCalibration, GyroScalesDoNotDependOnEncoderAndImuRates) {
  // The rate runs' angles must not depend on where the encoder and IMU samples fall relative
  // to the runs' ramps: slow encoders (10 Hz) and other IMU rates give the truth as well.
  const SensorModel truth = exampleSensors();
  const Motion motion = libraryMotion("direct_two_axis");
  for (const auto& [imu_hz, table_hz] :
       {std::pair{50.0, 10.0}, std::pair{200.0, 10.0}, std::pair{100.0, 100.0}}) {
    const DirectCalibrationInput in =
        simulateDirect(motion, truth, {}, NoiseModel::none(), imu_hz, table_hz);
    const DirectCalibrationResult r = calibrateDirect(in);
    ASSERT_TRUE(r.status.HasResult()) << r.status.message;
    const SensorModel& est = r.report.values.sensors;
    EXPECT_LT((est.gyro.scale - truth.gyro.scale).cwiseAbs().maxCoeff(), 1e-12)
        << "imu " << imu_hz << " Hz, encoder " << table_hz
        << " Hz: " << (est.gyro.scale - truth.gyro.scale).transpose();
    EXPECT_LT(misDiff(est.gyro.mis, truth.gyro.mis), 1e-10) << imu_hz << " / " << table_hz;
  }
}

TEST(DirectCalibration, GyroMisalignmentsDoNotDependOnTheEncoderReplyLatency) {
  // A table controller answers while it turns with its reply latency: the daemon stamps each
  // reading with the IMU time at the reply, late by 0.2-0.6 s here (a loaded host at 20x),
  // and a stalled poll leaves seconds without a reading.
  // The rate runs' Earth-rate input must not follow those stamps (interpolated, they put
  // 0.28 arcsec into the gyro misalignments here); at rest the stamps do not matter.
  const SensorModel truth = exampleSensors();
  DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), truth, {}, NoiseModel::none(), 50.0, 20.0);
  int late = 0;
  for (std::size_t k = 1; k + 1 < in.table.size(); ++k) {
    TableSample& s = in.table[k];
    for (const Segment& seg : in.segments) {
      const double latency = 0.4 + 0.2 * std::sin(0.7 * static_cast<double>(k));
      const bool turning = in.table[k - 1].angles.outer != in.table[k + 1].angles.outer ||
                           in.table[k - 1].angles.inner != in.table[k + 1].angles.inner;
      if (seg.kind != SegmentKind::kRotate || s.t <= seg.t0 || s.t + latency >= seg.t1 ||
          !turning) {
        continue;
      }
      s.t += latency;
      ++late;
      break;
    }
  }
  std::stable_sort(in.table.begin(), in.table.end(),
                   [](const TableSample& a, const TableSample& b) { return a.t < b.t; });
  ASSERT_GT(late, 1000);
  // ... and polling stalls: no reading over the last 4 s of each turn (its braking ramp).
  std::erase_if(in.table, [&](const TableSample& s) {
    return std::any_of(in.segments.begin(), in.segments.end(), [&](const Segment& seg) {
      return seg.kind == SegmentKind::kRotate && s.t > seg.t1 - 4.0 && s.t < seg.t1 - 0.1;
    });
  });
  const DirectCalibrationResult r = calibrateDirect(in);
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  const SensorModel& est = r.report.values.sensors;
  EXPECT_LT(misDiff(est.gyro.mis, truth.gyro.mis), 1e-10)
      << misDiff(est.gyro.mis, truth.gyro.mis) / kArcsecToRad << " arcsec";
  EXPECT_LT((est.gyro.scale - truth.gyro.scale).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(DirectCalibration, RefusesARecordingWithoutStatics) {
  DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), exampleSensors(), {});
  std::vector<Segment> rot;
  for (const Segment& s : in.segments)
    if (s.kind != SegmentKind::kStatic) rot.push_back(s);
  in.segments = rot;
  const DirectCalibrationResult r = calibrateDirect(in);
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("static"), std::string::npos) << r.status.message;
}

TEST(DirectCalibration, RefusesNaNSamples) {
  DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), exampleSensors(), {});
  in.imu[1000].dvel.x() = std::nan("");
  const DirectCalibrationResult r = calibrateDirect(in);
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("sample 1000"), std::string::npos) << r.status.message;
}

TEST(DirectCalibration, RefusesARecordingWithMissingSamples) {
  DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), exampleSensors(), {});
  in.imu.erase(in.imu.begin() + 5000, in.imu.begin() + 5100);  // 2 s lost at 50 Hz
  const DirectCalibrationResult r = calibrateDirect(in);
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("IMU sample 5000"), std::string::npos) << r.status.message;
  EXPECT_NE(r.status.message.find("samples missing"), std::string::npos) << r.status.message;
}

TEST(DirectCalibration, RefusesSamplesAtTheImuRange) {
  // The plan's rate runs turn at 30 deg/s; a 20 deg/s gyro clips them.
  const DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), exampleSensors(), {});
  DirectCalibrationOptions o;
  o.checks.gyro_range_radps = 20.0 * kDegToRad;
  const DirectCalibrationResult r = calibrateDirect(in, o);
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("at its range limit"), std::string::npos) << r.status.message;
  o.checks.gyro_range_radps = 100.0 * kDegToRad;  // a range the plan stays inside
  EXPECT_TRUE(calibrateDirect(in, o).status.HasResult());
}

TEST(DirectCalibration, NamesParametersAPoorPlanCannotSeparate) {
  // Only z up/down and y up/down, no rate runs: x_B is always horizontal, so nothing excites
  // the accelerometers' x input: accel.scale.x and the misalignments on it (yx, zx) cannot
  // be separated from the rest and must be named and flagged, not silently returned.
  DirectCalibrationInput in =
      simulateDirect(libraryMotion("direct_two_axis"), exampleSensors(), {});
  std::vector<Segment> keep;
  for (const Segment& s : in.segments)
    if (s.kind == SegmentKind::kStatic && (s.label == "pos01_z_up" || s.label == "pos02_y_up" ||
                                           s.label == "pos04_y_down" || s.label == "pos06_z_down"))
      keep.push_back(s);
  ASSERT_EQ(keep.size(), 4u);
  in.segments = keep;
  const DirectCalibrationResult r = calibrateDirect(in);
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  bool named = false;
  for (const std::string& n : r.notes)
    named = named || n.find("accel.scale.x") != std::string::npos;
  EXPECT_TRUE(named);
  EXPECT_FALSE(r.report.uncertainty.at("accel.scale.x").observable);
  EXPECT_FALSE(r.report.uncertainty.at("accel.misalignment.yx").observable);
  EXPECT_FALSE(r.report.uncertainty.at("accel.misalignment.zx").observable);
  EXPECT_TRUE(r.report.uncertainty.at("accel.scale.z").observable);
  EXPECT_TRUE(r.report.uncertainty.at("accel.bias.y").observable);
}

}  // namespace
}  // namespace imubench::calib
