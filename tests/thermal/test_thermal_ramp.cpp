// Issue 16 item 3 "and from the continuous ramp": the chamber ramps -40 -> +60 -> -40 degC
// while the direct plan repeats (tests/thermal/thermal_scenario.h rampSchedule, the one lag
// model); calib::thermalPointsFromRun makes one point of each repetition ("up/rep03/..."
// labels) with its leg's rate, and calib::fitThermalRuns' refinement passes (each repetition
// moved to its mean temperature through the previous fit) remove most of the bias the
// within-repetition drift puts into a plain direct calibration. Must-show 2's numbers (both
// plans' chamber times and accuracies) are printed by bench/calibration/bench_thermal.cpp.
#include <gtest/gtest.h>

#include <iostream>

#include "calib/thermal/thermal_fit.h"
#include "tests/calibration/test_indirect_plan_loader.h"
#include "tests/thermal/thermal_sim.h"

namespace imubench::calib {
namespace {

constexpr double kImuRateHz = 10.0;  // the accuracy is judged against the noise floor

const Motion& body() {
  static const Motion m = testing::libraryMotion("direct_two_axis");
  return m;
}

struct RampFit {
  testing::RampSchedule schedule;
  ThermalRunsFitResult plain, refined;  // 0 and 2 refinement passes
  ThermalRunsFitResult joint;           // fitThermalJoint: every row at its own temperature
  testing::ThermalAccuracy plain_acc, refined_acc, joint_acc;
};

const RampFit& rampFit() {
  static const RampFit f = [] {
    RampFit r;
    const testing::ThermalScheduleOptions o;
    r.schedule = testing::rampSchedule(body(), o);
    const model::ThermalCoefficients truth = testing::cubicThermalTruth();
    const NoiseModel noise = NoiseModel::navigationGrade();
    const DirectCalibrationInput run =
        testing::simulateThermal(r.schedule.motion, &truth, noise, kImuRateHz, 300);
    ThermalRunsFitOptions fo;
    // The plain fit is the unrefined baseline: its drift misfit accepted like a first pass.
    fo.points.direct.quality =
        fo.points.direct.quality.acceptingMisfit(fo.max_normalised_rms_before_last);
    fo.refinements = 0;
    r.plain = fitThermalRuns({{run, "ramp"}}, fo);
    fo.refinements = 2;
    r.refined = fitThermalRuns({{run, "ramp"}}, fo);
    r.joint = fitThermalJoint({{run, "ramp"}});
    if (r.joint.status.HasResult()) {
      r.joint_acc =
          testing::thermalAccuracy(r.joint.fit.coefficients, truth, body(), noise, kImuRateHz);
    }
    if (r.plain.status.HasResult()) {
      r.plain_acc =
          testing::thermalAccuracy(r.plain.fit.coefficients, truth, body(), noise, kImuRateHz);
    }
    if (r.refined.status.HasResult()) {
      r.refined_acc =
          testing::thermalAccuracy(r.refined.fit.coefficients, truth, body(), noise, kImuRateHz);
    }
    return r;
  }();
  return f;
}

TEST(ThermalRamp, EachRepetitionIsAPointWithItsLegsRate) {
  const RampFit& f = rampFit();
  ASSERT_TRUE(f.refined.status.HasResult()) << f.refined.status.message;
  EXPECT_EQ(f.refined.passes, 3);
  const int reps = f.schedule.reps_up + f.schedule.reps_down;
  ASSERT_EQ(static_cast<int>(f.refined.points.size()), reps);
  const testing::ThermalScheduleOptions o;
  for (int i = 0; i < reps; ++i) {
    const ThermalFitPoint& p = f.refined.points[static_cast<std::size_t>(i)];
    const bool up = i < f.schedule.reps_up;
    EXPECT_NE(p.source.find(up ? "'up/rep" : "'down/rep"), std::string::npos) << p.source;
    // Away from the turns the IMU moves at the chamber's rate, in the leg's direction.
    const bool steady = i > 1 && i + 2 < reps && std::abs(i - f.schedule.reps_up) > 1;
    if (steady) {
      EXPECT_NEAR(p.temp_rate, (up ? 1 : -1) * o.ramp_rate, 0.05 * o.ramp_rate) << p.source;
    }
    // A repetition spans its duration's worth of ramp, a few degC.
    EXPECT_LT(p.temp_span_c, 1.1 * o.ramp_rate * body().duration + 0.1) << p.source;
  }
  ASSERT_TRUE(f.refined.fit.status.HasResult()) << f.refined.fit.status.message;
  EXPECT_TRUE(f.refined.fit.hysteresis_candidate);
  EXPECT_LT(f.refined.fit.coefficients.t_min_c, -37.0);
  EXPECT_GT(f.refined.fit.coefficients.t_max_c, 57.0);
}

TEST(ThermalRamp, RefinementRemovesMostOfTheWithinRepetitionDriftBias) {
  const RampFit& f = rampFit();
  ASSERT_TRUE(f.plain.status.HasResult()) << f.plain.status.message;
  ASSERT_TRUE(f.refined.status.HasResult()) << f.refined.status.message;
  ASSERT_TRUE(f.plain_acc.error.empty() && f.refined_acc.error.empty());
  const testing::ThermalScheduleOptions o;
  const testing::SoakSchedule soak = testing::soakSchedule(body().duration, o);
  std::cout << "chamber time: ramp " << f.schedule.chamber_time_s / 3600.0 << " h, soak points "
            << soak.chamber_time_s / 3600.0 << " h\n";
  for (const auto* a : {&f.plain_acc, &f.refined_acc}) {
    std::cout << (a == &f.plain_acc ? "plain" : "refined") << " ramp fit: worst residual / noise "
              << "floor accel " << a->worst_accel << ", gyro " << a->worst_gyro
              << "; worst bias tempco error " << 100.0 * a->worst_bias_tempco << " %\n";
  }
  EXPECT_FALSE(f.refined_acc.extrapolated);
  EXPECT_LT(f.refined_acc.worst_accel, 0.25 * f.plain_acc.worst_accel);
  EXPECT_LT(f.refined_acc.worst_bias_tempco, 0.25 * f.plain_acc.worst_bias_tempco);
  EXPECT_LT(f.refined_acc.worst_gyro, f.plain_acc.worst_gyro);
  EXPECT_LT(f.schedule.chamber_time_s, soak.chamber_time_s);
}

// The joint fit from the raw rows (each static and rate run at its own temperature and rate)
// recovers the cubic truth from the ramp within must-show 1's tolerances: compensated static
// residuals at the 10 held-out temperatures within 2x the noise floor, bias temperature
// coefficients within 5 %, the biases' hysteresis found; and it beats the per-repetition fit.
TEST(ThermalRamp, JointFitRecoversCubicTruthWithinTheMustShowTolerances) {
  const RampFit& f = rampFit();
  ASSERT_TRUE(f.joint.status.HasResult()) << f.joint.status.message;
  ASSERT_TRUE(f.joint_acc.error.empty()) << f.joint_acc.error;
  std::cout << "joint ramp fit (" << f.joint.passes << " sweeps): worst residual / noise floor "
            << "accel " << f.joint_acc.worst_accel << ", gyro " << f.joint_acc.worst_gyro
            << "; worst bias tempco error " << 100.0 * f.joint_acc.worst_bias_tempco << " %\n";
  EXPECT_FALSE(f.joint_acc.extrapolated);
  EXPECT_LT(f.joint_acc.worst_accel, 2.0);
  EXPECT_LT(f.joint_acc.worst_gyro, 2.0);
  EXPECT_LT(f.joint_acc.worst_bias_tempco, 0.05);
  EXPECT_LT(f.joint.passes, ThermalJointFitOptions{}.max_sweeps);  // converged
  EXPECT_TRUE(f.joint.fit.hysteresis_candidate);
  const model::ThermalCoefficients truth = testing::cubicThermalTruth();
  for (const bool accel : {true, false}) {
    for (int i = model::kBias; i < model::kBias + 3; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const auto& fit = (accel ? f.joint.fit.coefficients.accel : f.joint.fit.coefficients.gyro)[u];
      const auto& t = (accel ? truth.accel : truth.gyro)[u];
      EXPECT_EQ(fit.order, 3) << thermalCoefficientName(accel ? "accel" : "gyro", i);
      ASSERT_TRUE(fit.hysteresis) << thermalCoefficientName(accel ? "accel" : "gyro", i);
      EXPECT_NEAR(fit.dTdt, t.dTdt, 0.05 * std::abs(t.dTdt));
    }
  }
  if (f.refined.status.HasResult() && f.refined_acc.error.empty()) {
    EXPECT_LT(f.joint_acc.worst_accel, f.refined_acc.worst_accel);
    EXPECT_LT(f.joint_acc.worst_bias_tempco, f.refined_acc.worst_bias_tempco);
  }
}

TEST(ThermalRamp, JointFitRefusesARecordingWithoutTemperatures) {
  DirectCalibrationInput run;
  run.imu.resize(3);
  const ThermalRunsFitResult r = fitThermalJoint({{run, "rec.csv"}});
  EXPECT_FALSE(r.status.HasResult());
  EXPECT_NE(r.status.message.find("rec.csv: the recording has no IMU temperatures"),
            std::string::npos)
      << r.status.message;
}

TEST(ThermalRamp, RefusesAZeroWindowSpan) {
  ThermalPointOptions o;
  o.max_point_span_c = 0.0;
  DirectCalibrationInput run;
  run.imu.push_back(nav::ImuSample{});
  run.imu.back().temp_c = 20.0;
  const ThermalPointsResult r = thermalPointsFromRun(run, "x", o);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("max_point_span_c"), std::string::npos) << r.status.message;
}

}  // namespace
}  // namespace imubench::calib
