// The one calibration policy (calib/service/calibration_service.h): the method the motion supports,
// the start values, what is done with every table error, one gate; and the three-axis
// schedule whose runs follow a move after a short settle only (no hold before them), on a
// table with realistic errors.
#include <gtest/gtest.h>

#include <string>

#include "calib/service/calibration_service.h"
#include "calib/simulator.h"
#include "nav/rotation.h"
#include "test_direct_sim.h"
#include "test_indirect_motions.h"

namespace imubench::calib {
namespace {

using testing::exampleSensors;
using testing::exampleSite;
using testing::MotionBuilder;

struct SimulatedRecording {
  Simulation sim;
  RecordingView view() const {
    return {TableGeometry{sim_kind}, exampleSite(), sim.imu, sim.table, sim.segments};
  }
  TableKind sim_kind = TableKind::kTwoAxis;
};

SimulatedRecording simulateOn(const Motion& motion, const TableErrors& table, std::uint64_t seed,
                              const NoiseModel& noise = NoiseModel::navigationGrade()) {
  SimulatorInput si;
  si.world.site = exampleSite();
  si.world.truth.sensors = exampleSensors();
  si.world.truth.table = table;
  si.world.truth.table_kind = motion.kind;
  si.world.noise = noise;
  si.motion = motion;
  SimOptions so;
  so.imu_rate_hz = 100.0;
  so.table_rate_hz = 50.0;
  so.seed = seed;
  SimulatedRecording r;
  r.sim = simulate(si, so);
  r.sim_kind = motion.kind;
  EXPECT_TRUE(r.sim.status.ok) << r.sim.status.message;
  return r;
}

// Realistic errors of a three-axis table: 20-60 arcsec on every geometric term.
TableErrors realisticThreeAxisTable() {
  TableErrors t;
  t.base_tilt = Vec2(35.0, -48.0) * kArcsecToRad;
  t.nonorthogonality.middle_x = 22.0 * kArcsecToRad;
  t.nonorthogonality.middle_y = -41.0 * kArcsecToRad;
  t.nonorthogonality.inner_y = 57.0 * kArcsecToRad;
  t.mounting = Vec2(-30.0, 26.0) * kArcsecToRad;
  t.encoder_zero.outer = 44.0 * kArcsecToRad;
  t.encoder_zero.middle = -25.0 * kArcsecToRad;
  t.encoder_zero.inner = 31.0 * kArcsecToRad;
  return t;
}

// The three-axis schedule with each placement's first run right after the move and a 2 s
// settle (no hold before it), the second after a full hold.
Motion threeAxisSettleBeforeRuns() {
  MotionBuilder b(TableKind::kThreeAxis);
  struct Placement {
    double outer, middle, inner;
    int axis;
    const char* name;
  };
  const Placement p[6] = {{0, 0, 0, 1, "x1"},    {90, 90, 0, 1, "x2"}, {0, 0, 90, 1, "y1"},
                          {90, 90, 90, 1, "y2"}, {0, 90, 0, 2, "z1"},  {90, -90, 90, 2, "z2"}};
  int run = 0;
  for (const Placement& pl : p) {
    b.moveTo({pl.outer, pl.middle, pl.inner}, std::string("to-") + pl.name);
    b.hold(2.0, std::string("settle-") + pl.name);
    for (double dir : {180.0, -180.0}) {
      ++run;
      b.rotate(pl.axis, dir, "run" + std::to_string(run) + "-" + pl.name);
      b.hold(40.0, "hold-run" + std::to_string(run));
    }
  }
  return b.finish();
}

const TableParamDecision* decision(const CalibrationOutcome& c, const std::string& name) {
  for (const TableParamDecision& d : c.table) {
    if (d.name == name) return &d;
  }
  return nullptr;
}

TEST(CalibrationService, HoldsOnlyGetTheDirectCalibrationAndEveryTableErrorIsHeldWithAReason) {
  MotionBuilder b(TableKind::kTwoAxis);
  const double poses[6][2] = {{0, 0}, {180, 0}, {90, 0}, {-90, 0}, {90, 90}, {-90, 90}};
  for (const auto& p : poses) {
    b.moveTo({p[0], p[1]}, "to");
    b.hold(30.0, "hold");
  }
  const SimulatedRecording r = simulateOn(b.finish(), TableErrors{}, 11);
  CalibrationRequest rq;
  rq.recording = r.view();
  const CalibrationOutcome c = calibrateRecording(rq);
  EXPECT_EQ(c.method, ServiceMethod::kDirect);
  EXPECT_EQ(c.runs, 0);
  EXPECT_NE(c.why_method.find("without rotation runs"), std::string::npos) << c.why_method;
  ASSERT_FALSE(c.table.empty());
  for (const TableParamDecision& d : c.table) {
    EXPECT_FALSE(d.estimated) << d.name;
    EXPECT_NE(d.reason.find("direct calibration takes the table as nominal"), std::string::npos)
        << d.name << ": " << d.reason;
  }
}

TEST(CalibrationService, RunsOnATableWithErrorsGetTheNavigationMethodThatEstimatesThem) {
  TableErrors table;
  table.base_tilt = Vec2(30.0, -25.0) * kArcsecToRad;
  table.nonorthogonality.inner_y = 20.0 * kArcsecToRad;
  const SimulatedRecording r = simulateOn(testing::twoAxis12Run(30.0), table, 12);
  CalibrationRequest rq;
  rq.recording = r.view();
  const CalibrationOutcome c = calibrateRecording(rq);
  ASSERT_TRUE(c.status.HasResult()) << c.status.message;
  EXPECT_TRUE(c.status.IsSolutionUsable()) << c.status.message;
  EXPECT_EQ(c.method, ServiceMethod::kNavigation);
  EXPECT_EQ(c.start, "direct calibration");
  ASSERT_NE(decision(c, "table.base_tilt.x"), nullptr);
  EXPECT_TRUE(decision(c, "table.base_tilt.x")->estimated);
  EXPECT_TRUE(decision(c, "table.nonorthogonality.inner_y")->estimated);
  EXPECT_FALSE(decision(c, "table.mounting.x")->estimated);
  EXPECT_NE(decision(c, "table.mounting.x")->reason.find("gyro-referenced"), std::string::npos);
  const std::vector<std::string> est = c.estimatedTableParams();
  EXPECT_EQ(est, (std::vector<std::string>{"table.base_tilt.x", "table.base_tilt.y",
                                           "table.nonorthogonality.inner_y"}));
  // Outer encoder zero is absorbed in the tilt about the outer axis: none in the truth here.
  const Vec2 tilt = c.coefficients.values.table.base_tilt;
  EXPECT_NEAR(tilt.x(), table.base_tilt.x(), 3.0 * kArcsecToRad);
  EXPECT_NEAR(tilt.y(), table.base_tilt.y(), 3.0 * kArcsecToRad);
}

TEST(CalibrationService, KnownTableErrorsAreHeldAsCertificationData) {
  TableErrors table;
  table.nonorthogonality.inner_y = 20.0 * kArcsecToRad;
  const SimulatedRecording r = simulateOn(testing::twoAxis12Run(30.0), table, 13);
  CalibrationRequest rq;
  rq.recording = r.view();
  rq.method = ServiceMethod::kNavigation;
  rq.known_table_errors = table;
  const CalibrationOutcome c = calibrateRecording(rq);
  ASSERT_TRUE(c.status.HasResult()) << c.status.message;
  const TableParamDecision* nu = decision(c, "table.nonorthogonality.inner_y");
  ASSERT_NE(nu, nullptr);
  EXPECT_FALSE(nu->estimated);
  EXPECT_NE(nu->reason.find("certification"), std::string::npos) << nu->reason;
  EXPECT_EQ(c.coefficients.values.table.nonorthogonality.inner_y, table.nonorthogonality.inner_y);
}

TEST(CalibrationService, ThreeAxisRunsAfterOnlyASettleAreUsedOnARealisticTable) {
  // The production pipeline: the bundled direct three-axis plan, then the navigation schedule
  // whose first run of every placement follows the move after a 2 s settle only.
  const TableErrors table = realisticThreeAxisTable();
  const SimulatedRecording d = simulateOn(testing::libraryMotion("direct_three_axis"), table, 15);
  const SimulatedRecording r = simulateOn(threeAxisSettleBeforeRuns(), table, 14);
  CalibrationRequest rq;
  rq.recording = r.view();
  rq.direct = d.view();
  const CalibrationOutcome c = calibrateRecording(rq);
  ASSERT_TRUE(c.status.HasResult()) << c.status.message;
  EXPECT_TRUE(c.status.IsSolutionUsable()) << c.status.message;
  ASSERT_TRUE(c.refined.has_value());
  std::string said = c.why_method + "\n";
  for (const std::string& why : c.status.reasons) said += "  " + why + "\n";
  for (const std::string& w : c.refined->warnings) said += "  warning: " + w + "\n";
  said += "  passes " + std::to_string(c.passes) + ", runs normalised RMS " +
          std::to_string(c.refined->run_normalised_rms) + ", holds " +
          std::to_string(c.refined->accel_normalised_rms) + "/" +
          std::to_string(c.refined->gyro_normalised_rms);
  SCOPED_TRACE(said);
  for (const std::string& w : c.refined->warnings) {
    EXPECT_EQ(w.find("no usable hold"), std::string::npos) << w;
  }
  // The frame-independent truth (calib/indirect/indirect_calibration.h): tilt, nonorthogonality
  // with the middle encoder zero in middle_x.
  BenchTruth truth;
  truth.sensors = exampleSensors();
  truth.table = table;
  truth.table_kind = TableKind::kThreeAxis;
  const GyroReferencedTruth g = toGyroReferenced(truth, TableGeometry{TableKind::kThreeAxis});
  const TableErrors& est = c.coefficients.values.table;
  const double tol = 3.0 * kArcsecToRad;
  EXPECT_NEAR(est.base_tilt.x(), g.base_tilt.x(), tol);
  EXPECT_NEAR(est.base_tilt.y(), g.base_tilt.y(), tol);
  EXPECT_NEAR(est.nonorthogonality.middle_x, g.nonorthogonality.middle_x, tol);
  EXPECT_NEAR(est.nonorthogonality.middle_y, g.nonorthogonality.middle_y, tol);
  EXPECT_NEAR(est.nonorthogonality.inner_y, g.nonorthogonality.inner_y, tol);
  const SensorModel& s = c.coefficients.values.sensors;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(s.accel.scale[i], g.sensors.accel.scale[i], 10e-6) << "accel scale " << i;
    EXPECT_NEAR(s.gyro.scale[i], g.sensors.gyro.scale[i], 10e-6) << "gyro scale " << i;
  }
  const Mat3 d_accel = s.accel.M() - g.sensors.accel.M();
  const Mat3 d_gyro = s.gyro.M() - g.sensors.gyro.M();
  EXPECT_LT(d_accel.cwiseAbs().maxCoeff(), tol) << "accel misalignments\n" << d_accel;
  EXPECT_LT(d_gyro.cwiseAbs().maxCoeff(), tol) << "gyro misalignments\n" << d_gyro;
}

}  // namespace
}  // namespace imubench::calib
