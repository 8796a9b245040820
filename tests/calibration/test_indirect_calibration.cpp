// Navigation-based (indirect) calibration on simulated benches with known truth: the seed's
// two-axis 12-run schedule and the three-axis schedule, navigation-grade sensors, table errors
// of 10-60 arcsec. Accuracy targets (issue 3 item 2): base tilt and misalignments
// (gyro-referenced) within 3 arcsec, scale factors within 10 ppm, biases within 2 sigma.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calib/indirect/indirect_calibration.h"
#include "calib/simulator.h"
#include "test_indirect_common.h"
#include "test_indirect_motions.h"

namespace imubench::calib {
namespace {

using namespace testing;

TEST(IndirectCalibration, TwoAxis12RunRecoversTruth) {
  const Bench bench = randomBench(11, TableKind::kTwoAxis);
  const Outcome o = runBench(testing::twoAxis12Run(), bench, 5, 100.0);
  expectAccurate(o);
}

TEST(IndirectCalibration, ThreeAxisRecoversTruth) {
  const Bench bench = randomBench(12, TableKind::kThreeAxis);
  const Outcome o = runBench(testing::threeAxisIndirect(), bench, 6, 100.0);
  expectAccurate(o);
}

// Physics check that the test above can fail: with the base tilt held at zero (the direct
// method's assumption) the accelerometer misalignments absorb it and miss the
// gyro-referenced truth by about the tilt.
TEST(IndirectCalibration, IgnoringBaseTiltBiasesAccelMisalignment) {
  Bench bench = randomBench(11, TableKind::kTwoAxis);
  bench.truth.table.base_tilt = Vec2(50.0, -40.0) * kArcsecToRad;
  SimulatorInput si;
  si.world.site.latitude_rad = 58.0 * kDegToRad;
  si.world.truth = bench.truth;
  si.world.noise = bench.noise;
  si.motion = testing::twoAxis12Run();
  SimOptions so;
  so.imu_rate_hz = 100.0;
  so.table_rate_hz = 10.0;
  const Simulation sim = simulate(si, so);
  ASSERT_TRUE(sim.status.ok) << sim.status.message;
  IndirectInput in;
  in.site = si.world.site;
  in.imu = sim.imu;
  in.table = sim.table;
  in.segments = sim.segments;
  IndirectOptions opt;
  opt.estimate_base_tilt = false;
  const CalibrationResult r = calibrateIndirect(in, opt);
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  const GyroReferencedTruth t = toGyroReferenced(bench.truth, in.geometry);
  double worst = 0.0;
  for (const char* m : {"xy", "xz", "yx", "yz", "zx", "zy"}) {
    const std::string n = std::string("accel.misalignment.") + m;
    BenchTruth tt;
    tt.sensors = t.sensors;
    worst = std::max(worst, std::abs(*flatValue(r.coefficients.values, n) - *flatValue(tt, n)));
  }
  EXPECT_GT(worst * kRadToArcsec, 10.0);
  // And the fit is visibly worse than the noise (the tilt does not fit the model).
  EXPECT_GT(r.rms_normalised_residual, 2.0);
}

// issue 26: an under-modelled recording (a 50"/-40" base tilt held at zero) prints sigmas
// scaled by the measured residual, not the precision of its noise alone: the accelerometer
// scale and bias sigmas (which the tilt hardly correlates with) grow with the accelerometer
// holds' normalised RMS against the fit of the same recording that estimates the tilt.
TEST(IndirectCalibration, UnderModelledRecordingScalesItsSigmas) {
  const auto fit = [](bool estimate_tilt) {
    Bench bench = randomBench(11, TableKind::kTwoAxis);
    bench.truth.table.base_tilt = Vec2(50.0, -40.0) * kArcsecToRad;
    SimulatorInput si;
    si.world.site.latitude_rad = 58.0 * kDegToRad;
    si.world.truth = bench.truth;
    si.world.noise = bench.noise;
    si.motion = testing::twoAxis12Run();
    SimOptions so;
    so.imu_rate_hz = 100.0;
    so.table_rate_hz = 10.0;
    const Simulation sim = simulate(si, so);
    EXPECT_TRUE(sim.status.ok) << sim.status.message;
    IndirectInput in;
    in.site = si.world.site;
    in.imu = sim.imu;
    in.table = sim.table;
    in.segments = sim.segments;
    IndirectOptions opt;
    opt.estimate_base_tilt = estimate_tilt;
    return calibrateIndirect(in, opt);
  };
  const CalibrationResult clean = fit(true);
  const CalibrationResult tilted = fit(false);
  ASSERT_TRUE(clean.status.HasResult()) << clean.status.message;
  ASSERT_TRUE(tilted.status.HasResult()) << tilted.status.message;
  ASSERT_GT(tilted.accel_normalised_rms, 2.0);
  EXPECT_DOUBLE_EQ(tilted.accel_sigma_factor, tilted.accel_normalised_rms);
  EXPECT_LT(clean.accel_sigma_factor, 1.5);
  for (const char* n : {"accel.scale.x", "accel.scale.z", "accel.bias.y", "accel.bias.z"}) {
    const double s_clean = *clean.coefficients.uncertainty.at(n).sigma;
    const double s_tilted = *tilted.coefficients.uncertainty.at(n).sigma;
    EXPECT_GT(s_tilted, 0.8 * tilted.accel_sigma_factor / clean.accel_sigma_factor * s_clean) << n;
  }
}

// A plan that turns only about one axis with the z axis up/down cannot see most gyro
// coefficients nor the horizontal accelerometer scales: they are fixed, flagged and named.
TEST(IndirectCalibration, UnobservableParametersAreFixedAndNamed) {
  testing::MotionBuilder b(TableKind::kTwoAxis);
  b.hold(60.0, "a");
  b.rotate(0, 180.0, "r1");
  b.hold(60.0, "b");
  b.rotate(0, -180.0, "r2");
  b.hold(60.0, "c");
  const Bench bench = randomBench(3, TableKind::kTwoAxis);
  const Outcome o = runBench(b.finish(), bench, 9, 100.0);
  ASSERT_TRUE(o.result.status.HasResult()) << o.result.status.message;
  const auto& fixed = o.result.conditioning.fixed_unobservable;
  EXPECT_FALSE(fixed.empty());
  auto contains = [&fixed](const std::string& n) {
    return std::find(fixed.begin(), fixed.end(), n) != fixed.end();
  };
  EXPECT_TRUE(contains("accel.scale.x")) << o.result.conditioning.describe();
  EXPECT_TRUE(contains("gyro.scale.y")) << o.result.conditioning.describe();
  for (const std::string& n : fixed) {
    EXPECT_FALSE(o.result.coefficients.uncertainty.at(n).observable) << n;
  }
  // What the plan does see is still estimated: the rotation axis' gyro scale factor.
  const CoefficientReport& r = o.result.coefficients;
  EXPECT_TRUE(r.uncertainty.at("gyro.scale.x").observable);
  EXPECT_NEAR(
      *flatValue(r.values, "gyro.scale.x"),
      *flatValue(BenchTruth{o.expected.sensors, {}, TableKind::kTwoAxis, {}}, "gyro.scale.x"),
      10e-6);
}

TEST(IndirectCalibration, RefusesRecordingWithoutHolds) {
  nav::ImuSamples imu(100);
  for (std::size_t k = 0; k < imu.size(); ++k) imu[k].t = 0.01 * static_cast<double>(k + 1);
  std::vector<TableSample> table(1);
  std::vector<Segment> segs(1);
  segs[0].t0 = 0.0;
  segs[0].t1 = 1.0;
  segs[0].kind = SegmentKind::kStatic;
  IndirectInput in;
  in.imu = imu;
  in.table = table;
  in.segments = segs;
  const CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("no usable static hold"), std::string::npos) << r.status.message;
  EXPECT_FALSE(r.warnings.empty());
}

// A gap in the second recording (e.g. the direct plan's leg) is refused, naming that recording.
TEST(IndirectCalibration, RefusesAGapInAnyRecording) {
  nav::ImuSamples imu(1000), imu2(1000);
  for (std::size_t k = 0; k < imu.size(); ++k) {
    imu[k].t = imu2[k].t = 0.01 * static_cast<double>(k + 1);
    imu[k].dvel = imu2[k].dvel = Vec3(0, 0, 9.8 * 0.01);
  }
  for (std::size_t k = 600; k < imu2.size(); ++k) imu2[k].t += 3.0;  // 3 s of samples lost
  std::vector<TableSample> table(1);
  std::vector<Segment> segs(1);
  segs[0].t1 = 10.0;
  segs[0].kind = SegmentKind::kStatic;
  IndirectInput in;
  in.imu = imu;
  in.table = table;
  in.segments = segs;
  in.extra_legs.push_back({imu2, table, segs});
  const CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("recording 2: IMU sample 600"), std::string::npos)
      << r.status.message;
  EXPECT_NE(r.status.message.find("samples missing"), std::string::npos) << r.status.message;
}

}  // namespace
}  // namespace imubench::calib
