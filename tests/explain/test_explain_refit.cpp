// explain's joint refit (calib/explain/explain_fit.h refitJointly): its Gauss-Newton reaches the
// same optimum and sigmas as Ceres' Levenberg-Marquardt on the same residuals, and it reports how
// it ended (converged, or stopped at the iteration limit).
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "calib/explain/explain_fit.h"
#include "calib/noise.h"

namespace imubench::calib {
namespace {

const std::vector<std::string> kNames = {"accel.bias.x", "accel.scale.y", "gyro.bias.z"};

// A forward model nonlinear in its three parameters (p0 * exp(-p1 t) + cos(p2 t), and the
// other channels), so that Gauss-Newton needs several steps from a start far off.
class NonlinearForward : public ExplainForward {
 public:
  explicit NonlinearForward(int bins) : bins_(bins) {}
  void predict(const ExplainState& s, std::vector<double>* out) override {
    const double a = stateValue(s, kNames[0]), b = stateValue(s, kNames[1]);
    const double c = stateValue(s, kNames[2]);
    out->assign(static_cast<std::size_t>(bins_) * 6, 0.0);
    for (int i = 0; i < bins_; ++i) {
      const double t = 0.05 * i;
      double* o = out->data() + static_cast<std::ptrdiff_t>(6) * i;
      o[0] = a * std::exp(-b * t) + std::cos(c * t);
      o[1] = a * b * t;
      o[2] = std::sin(c * t) * b;
      o[3] = a * a * 0.1;
      o[4] = c * t;
      o[5] = b * std::cos(t);
    }
  }

 private:
  int bins_;
};

struct Fixture {
  static constexpr int kBins = 200;
  NonlinearForward forward{kBins};
  std::vector<ExplainBin> bins;
  std::vector<double> sigma;
  ExplainState truth, start;

  Fixture() {
    std::string why;
    setStateValue(&truth, kNames[0], 2.0, &why);
    setStateValue(&truth, kNames[1], 0.7, &why);
    setStateValue(&truth, kNames[2], 1.3, &why);
    start = truth;
    setStateValue(&start, kNames[0], 1.5, &why);
    setStateValue(&start, kNames[1], 0.5, &why);
    setStateValue(&start, kNames[2], 1.25, &why);
    std::vector<double> y;
    forward.predict(truth, &y);
    GaussianSource g(11);
    bins.resize(kBins);
    sigma.assign(y.size(), 0.01);
    for (int i = 0; i < kBins; ++i) {
      for (int k = 0; k < 6; ++k) {
        bins[i].measured[k] = y[6 * i + k] + 0.01 * g.next();
      }
    }
  }
};

// The same whitened residual as a Ceres cost over the three parameters.
struct WhitenedResidual {
  ExplainEvaluator* eval = nullptr;
  ExplainState base;
  bool operator()(double const* const* p, double* r) const {
    ExplainState s = base;
    std::string why;
    for (int j = 0; j < 3; ++j) setStateValue(&s, kNames[j], p[0][j], &why);
    const Eigen::VectorXd w = eval->residual(s);
    for (int i = 0; i < w.size(); ++i) r[i] = w(i);
    return true;
  }
};

TEST(ExplainRefit, GaussNewtonReachesCeresOptimumAndSigmas) {
  Fixture f;
  ExplainEvaluator eval(&f.bins, &f.forward, f.sigma, 1e-7);
  const RefitResult gn = refitJointly(&eval, f.start, kNames, RefitOptions{});
  ASSERT_TRUE(gn.status.ok) << gn.status.message;
  EXPECT_TRUE(gn.converged);
  EXPECT_GE(gn.iterations, 2);  // the start is far off: one linear step is not enough
  EXPECT_LE(gn.last_step_sigma, RefitOptions{}.tolerance_sigma);

  double p[3];
  for (int j = 0; j < 3; ++j) p[j] = stateValue(f.start, kNames[j]);
  auto* cost = new ceres::DynamicNumericDiffCostFunction<WhitenedResidual, ceres::CENTRAL>(
      new WhitenedResidual{&eval, f.start});
  cost->AddParameterBlock(3);
  cost->SetNumResiduals(eval.rows());
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, p);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.function_tolerance = 1e-15;
  so.parameter_tolerance = 1e-15;
  so.gradient_tolerance = 1e-15;
  so.max_num_iterations = 100;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  ASSERT_TRUE(sum.IsSolutionUsable()) << sum.FullReport();

  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {{p, p}};
  ASSERT_TRUE(cov.Compute(blocks, &problem));
  double c[9];
  cov.GetCovarianceBlock(p, p, c);
  const double dof = eval.rows() - 3;
  const double birge = std::max(1.0, 2.0 * sum.final_cost / dof);  // refit's max(1, chi2/dof)
  for (std::size_t j = 0; j < 3; ++j) {
    const double sigma_ceres = std::sqrt(c[4 * j] * birge);
    EXPECT_NEAR(stateValue(gn.state, kNames[j]), p[j], 1e-3 * sigma_ceres) << kNames[j];
    EXPECT_NEAR(gn.sigma[j], sigma_ceres, 1e-3 * sigma_ceres) << kNames[j];
    EXPECT_NEAR(stateValue(gn.state, kNames[j]), stateValue(f.truth, kNames[j]), 4 * gn.sigma[j]);
  }
  EXPECT_NEAR(gn.chi2, 2.0 * sum.final_cost, 1e-6 * gn.chi2);
}

// A copy for another thread: the evaluator then computes the Jacobian's columns on two.
class CloneableForward : public NonlinearForward {
 public:
  using NonlinearForward::NonlinearForward;
  std::unique_ptr<ExplainForward> clone() const override {
    return std::make_unique<CloneableForward>(*this);
  }
};

// The columns computed on several threads are the ones computed on one, bit for bit, and so
// is the refit built on them.
TEST(ExplainRefit, ThreadsChangeNoColumn) {
  Fixture f;
  CloneableForward cloneable{Fixture::kBins};
  ExplainEvaluator one(&f.bins, &f.forward, f.sigma, 1e-7, 1);
  std::vector<double> raw1, raw3;
  const Eigen::MatrixXd J1 = one.jacobian(f.start, kNames, &raw1);
  for (int threads : {2, 3, 8}) {
    ExplainEvaluator many(&f.bins, &cloneable, f.sigma, 1e-7, threads);
    const Eigen::MatrixXd J = many.jacobian(f.start, kNames, &raw3);
    ASSERT_EQ(J.cols(), J1.cols());
    EXPECT_TRUE((J.array() == J1.array()).all()) << threads << " threads";
    EXPECT_EQ(raw3, raw1) << threads << " threads";
    const RefitResult a = refitJointly(&one, f.start, kNames, RefitOptions{});
    const RefitResult b = refitJointly(&many, f.start, kNames, RefitOptions{});
    for (const std::string& n : kNames) EXPECT_EQ(stateValue(a.state, n), stateValue(b.state, n));
  }
}

TEST(ExplainRefit, StoppedAtTheIterationLimitIsReported) {
  Fixture f;
  ExplainEvaluator eval(&f.bins, &f.forward, f.sigma, 1e-7);
  RefitOptions o;
  o.max_iterations = 1;
  const RefitResult gn = refitJointly(&eval, f.start, kNames, o);
  ASSERT_TRUE(gn.status.ok) << gn.status.message;
  EXPECT_FALSE(gn.converged);
  EXPECT_EQ(gn.iterations, 1);
  EXPECT_GT(gn.last_step_sigma, o.tolerance_sigma);
}

TEST(ExplainRefit, InvalidOptionsAreRefused) {
  Fixture f;
  ExplainEvaluator eval(&f.bins, &f.forward, f.sigma, 1e-7);
  RefitOptions o;
  o.tolerance_sigma = 0.0;
  EXPECT_FALSE(refitJointly(&eval, f.start, kNames, o).status.ok);
}

}  // namespace
}  // namespace imubench::calib
