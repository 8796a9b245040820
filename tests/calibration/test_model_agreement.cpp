// One model, two users: the plan observability analysis (automatic differentiation of the
// forward model in calib/model/) and the navigation-based calibrator (its own Ceres problem on
// a recording of the plan, built from the same model functions) must see the same
// information — the same null space over the calibrator's parameters — on the 12-run plan and
// the three-axis plan.
#include <gtest/gtest.h>

#include "calib/indirect/indirect_calibration.h"
#include "calib/observability.h"
#include "test_direct_sim.h"

namespace imubench::calib {
namespace {

using testing::libraryMotion;

// Orthogonal projector onto the span of the first k eigenvectors of an analysis (ascending
// eigenvalues), rows in `order`'s parameter order.
Eigen::MatrixXd weakestProjector(const InformationAnalysis& a, Eigen::Index k,
                                 const std::vector<std::string>& order) {
  const Eigen::Index n = static_cast<Eigen::Index>(order.size());
  Eigen::MatrixXd basis(n, k);
  for (Eigen::Index d = 0; d < k; ++d) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto it = std::find(a.names.begin(), a.names.end(), order[static_cast<std::size_t>(i)]);
      EXPECT_NE(it, a.names.end()) << order[static_cast<std::size_t>(i)];
      basis(i, d) = it == a.names.end() ? 0.0 : a.eigenvectors(it - a.names.begin(), d);
    }
  }
  return basis * basis.transpose();
}

class ModelAgreement : public ::testing::TestWithParam<std::string> {};

TEST_P(ModelAgreement, PlanAnalysisAndCalibratorJacobianShareTheNullSpace) {
  const Motion motion = libraryMotion(GetParam());
  const PlanObservability plan = testing::indirectPlanAnalysis(motion);
  ASSERT_TRUE(plan.model_analysis.status.ok) << plan.model_analysis.status.message;

  // A recording of the nominal bench (the plan analysis linearises there; the calibrator's
  // Jacobian at its nominal start values then depends on the model alone, not on the data).
  const DirectCalibrationInput rec =
      testing::simulateDirect(motion, SensorModel{}, TableErrors{}, NoiseModel{}, 100.0, 10.0);
  IndirectInput in;
  in.recording() = viewOf(rec);
  const IndirectJacobian cal = indirectJacobian(in, IndirectOptions{});
  ASSERT_TRUE(cal.status.ok) << cal.status.message;
  const InformationAnalysis cal_info = analyseInformation(cal.jacobian, cal.names);
  ASSERT_TRUE(cal_info.status.ok) << cal_info.status.message;

  // Same parameter set, the same number of directions neither can see, the same subspace.
  std::vector<std::string> a = cal.names, b = plan.model_analysis.names;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  ASSERT_EQ(a, b);
  const Eigen::Index k = static_cast<Eigen::Index>(plan.model_analysis.null_directions.size());
  ASSERT_GT(k, 0) << "the plans leave directions unobservable";
  ASSERT_EQ(static_cast<Eigen::Index>(cal_info.null_directions.size()), k)
      << "eigenvalues: " << cal_info.eigenvalues.transpose();
  const Eigen::MatrixXd P_cal = weakestProjector(cal_info, k, cal.names);
  const Eigen::MatrixXd P_plan = weakestProjector(plan.model_analysis, k, cal.names);
  EXPECT_LT((P_cal - P_plan).norm(), 1e-3) << "calibrator:\n" << P_cal << "\nplan:\n" << P_plan;
}

INSTANTIATE_TEST_SUITE_P(Bundled, ModelAgreement,
                         ::testing::Values("two_axis_12run", "three_axis_indirect"));

}  // namespace
}  // namespace imubench::calib
