// Observability: the information-matrix core on a known Jacobian, and the bundled plans under
// the direct and navigation-based methods.
#include <gtest/gtest.h>

#include <set>

#include "calib/indirect/indirect_calibration.h"
#include "calib/observability.h"
#include "test_direct_sim.h"

namespace imubench::calib {
namespace {

using testing::exampleSite;
using testing::libraryMotion;

TEST(Information, NamesTheNullDirection) {
  // Columns a and b enter only as a - b... no: as a + b (identical columns): a - b is invisible.
  Eigen::MatrixXd J(3, 3);
  J << 1, 1, 0,  //
      2, 2, 1,   //
      0, 0, 3;
  const InformationAnalysis a = analyseInformation(J, {"mounting.x", "accel.misalignment.zy", "c"});
  ASSERT_TRUE(a.status.ok) << a.status.message;
  ASSERT_EQ(a.null_directions.size(), 1u);
  EXPECT_EQ(a.null_directions[0].description, "mounting.x + accel.misalignment.zy (0.71, -0.71)");
  EXPECT_FALSE(a.observable[0]);
  EXPECT_FALSE(a.observable[1]);
  EXPECT_TRUE(a.observable[2]);
}

TEST(Information, RefusesMismatchedNames) {
  EXPECT_FALSE(analyseInformation(Eigen::MatrixXd::Identity(2, 2), {"a"}).status.ok);
}

PlanObservability observe(const std::string& plan, CalibrationMethod m) {
  PlanObservabilityOptions o;
  o.site = exampleSite();
  const PlanObservability r = analysePlanObservability(libraryMotion(plan), m, o);
  EXPECT_TRUE(r.analysis.status.ok) << r.analysis.status.message;
  return r;
}

bool observable(const PlanObservability& r, const std::string& name) {
  for (std::size_t k = 0; k < r.analysis.names.size(); ++k)
    if (r.analysis.names[k] == name) return r.analysis.observable[k];
  ADD_FAILURE() << "no parameter " << name;
  return false;
}

bool says(const PlanObservability& r, const std::string& text) {
  for (const std::string& s : r.statements)
    if (s.find(text) != std::string::npos) return true;
  return false;
}

class AllPlans : public ::testing::TestWithParam<std::string> {};

TEST_P(AllPlans, MountingIsUnobservableByNavigationBasedCalibration) {
  const PlanObservability r = observe(GetParam(), CalibrationMethod::kIndirect);
  EXPECT_FALSE(observable(r, "table.mounting.x"));
  EXPECT_FALSE(observable(r, "table.mounting.y"));
  EXPECT_TRUE(says(r, "mounting angles (beta', gamma') cannot be estimated by navigation-based"));
}

TEST_P(AllPlans, StatementsAgreeWithTheInformationMatrix) {
  for (CalibrationMethod m : {CalibrationMethod::kDirect, CalibrationMethod::kIndirect}) {
    const PlanObservability r = observe(GetParam(), m);
    const InformationAnalysis& a = r.analysis;
    // Every parameter flagged unobservable has a component in some null direction, and
    // every null direction has an eigenvalue below the threshold.
    for (std::size_t k = 0; k < a.names.size(); ++k) {
      if (a.observable[k]) continue;
      bool found = false;
      for (const NullDirection& d : a.null_directions)
        found = found || std::abs(d.vector(static_cast<Eigen::Index>(k))) >= 0.05;
      EXPECT_TRUE(found) << a.names[k];
    }
    for (const NullDirection& d : a.null_directions)
      EXPECT_LT(d.eigenvalue, 1e-9 * a.eigenvalues.maxCoeff());
    const bool mount_ok = observable(r, "table.mounting.x") && observable(r, "table.mounting.y");
    EXPECT_EQ(says(r, "mounting angles (beta', gamma') can be estimated"), mount_ok);
  }
}

TEST_P(AllPlans, GravityErrorIsACommonAccelerometerScale) {
  const PlanObservability r = observe(GetParam(), CalibrationMethod::kDirect);
  EXPECT_FALSE(observable(r, "extra.gravity_error.dg_mps2"));
  EXPECT_TRUE(says(r, "gravity error is indistinguishable from a common accelerometer scale"));
}

INSTANTIATE_TEST_SUITE_P(Bundled, AllPlans,
                         ::testing::Values("direct_two_axis", "direct_three_axis", "two_axis_12run",
                                           "three_axis_indirect", "thermal_soak_12run",
                                           "validation_8heading"));

TEST(PlanObservability, DirectCalibrationCannotSeparateMountingFromMisalignments) {
  // The seed: mounting leaks into both triads' misalignments; with the table taken as nominal
  // the two are one direction of the information matrix.
  const PlanObservability r = observe("direct_two_axis", CalibrationMethod::kDirect);
  EXPECT_FALSE(observable(r, "table.mounting.x"));
  bool joint = false;
  for (const NullDirection& d : r.analysis.null_directions)
    joint = joint || (d.description.find("table.mounting") != std::string::npos &&
                      d.description.find("misalignment") != std::string::npos);
  EXPECT_TRUE(joint);
  EXPECT_TRUE(observable(r, "accel.bias.x"));
  EXPECT_TRUE(observable(r, "gyro.scale.z"));
}

// The plan analysis (before anything runs) and the calibrator (on a recording of the plan)
// must agree on what cannot be estimated: the navigation-based calibrator, without start
// values, fixes and flags exactly the parameters of its own set that the plan's information
// matrix says it cannot see.
class NavigationPlans : public ::testing::TestWithParam<std::string> {};

TEST_P(NavigationPlans, CalibratorFixesExactlyWhatThePlanAnalysisCannotSee) {
  const Motion motion = libraryMotion(GetParam());
  const PlanObservability plan = testing::indirectPlanAnalysis(motion);
  ASSERT_TRUE(plan.model_analysis.status.ok) << plan.model_analysis.status.message;
  std::set<std::string> blind_by_plan;
  for (std::size_t k = 0; k < plan.model_analysis.names.size(); ++k) {
    if (!plan.model_analysis.observable[k]) blind_by_plan.insert(plan.model_analysis.names[k]);
  }

  TableErrors table;
  table.base_tilt = Vec2(30, -20) * kArcsecToRad;
  table.nonorthogonality.inner_y = 25 * kArcsecToRad;
  const DirectCalibrationInput rec = testing::simulateDirect(
      motion, testing::exampleSensors(), table, NoiseModel::navigationGrade(), 100.0, 10.0);
  IndirectInput in;
  in.recording() = viewOf(rec);
  const CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
  ASSERT_TRUE(r.status.HasResult()) << r.status.message;
  const std::set<std::string> fixed(r.conditioning.fixed_unobservable.begin(),
                                    r.conditioning.fixed_unobservable.end());
  EXPECT_EQ(fixed, blind_by_plan) << r.conditioning.describe();
  for (const std::string& n : fixed) {
    ASSERT_TRUE(r.coefficients.uncertainty.count(n)) << n;
    EXPECT_FALSE(r.coefficients.uncertainty.at(n).observable) << n;
  }
}

INSTANTIATE_TEST_SUITE_P(Bundled, NavigationPlans,
                         ::testing::Values("two_axis_12run", "three_axis_indirect"));

}  // namespace
}  // namespace imubench::calib
