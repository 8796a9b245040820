// Numerical core of the model-discrepancy analysis (calib/explain/explain.h): whitened residuals
// and central-difference regressors of the forward model by flat coefficient name, projection off
// a column space, and the Gauss-Newton joint refit.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"
#include "calib/explain/explain_model.h"

namespace imubench::calib {

// Residuals and regressors of a model over the bins, whitened by per-row sigmas.
class ExplainEvaluator {
 public:
  // sigma: one per row (bin-major, 6 per bin).
  // threads: how many compute the Jacobian's columns (ExplainOptions::threads); the extra
  // ones use copies of `forward` (ExplainForward::clone; none: every column on the caller's).
  ExplainEvaluator(const std::vector<ExplainBin>* bins, ExplainForward* forward,
                   std::vector<double> sigma, double fd_step, int threads = 1);

  int rows() const { return static_cast<int>(sigma_.size()); }
  // Whitened residual (measured - predicted) / sigma of a model.
  Eigen::VectorXd residual(const ExplainState& state);
  // Unwhitened residual of a model (reading units), bin-major.
  std::vector<double> rawResidual(const ExplainState& state);
  // Whitened regressors d(prediction)/d(name) at the model; raw_max (if given) receives each
  // column's largest unwhitened magnitude.
  Eigen::MatrixXd jacobian(const ExplainState& state, const std::vector<std::string>& names,
                           std::vector<double>* raw_max = nullptr);
  const std::vector<double>& sigma() const { return sigma_; }

 private:
  // Column j of the Jacobian (and its largest unwhitened magnitude) with the forward model f.
  void column(ExplainForward* f, const ExplainState& state, const std::string& name, int j,
              Eigen::MatrixXd* J, double* raw_max) const;
  // The forward models of the extra threads for a Jacobian of `columns` columns (made once).
  std::vector<ExplainForward*> helpers(std::size_t columns);

  const std::vector<ExplainBin>* bins_;
  ExplainForward* forward_;
  std::vector<double> sigma_;
  double h_;
  int threads_;
  std::vector<std::unique_ptr<ExplainForward>> copies_;
  bool copies_made_ = false;
  std::vector<double> pred_;
};

// Orthonormal basis of the column space of A (columns normalised first; singular values
// below rel_tol times the largest are dropped). rank receives its size.
Eigen::MatrixXd columnBasis(const Eigen::MatrixXd& A, double rel_tol);
// x minus its projection on the orthonormal basis U.
inline Eigen::MatrixXd projectOff(const Eigen::MatrixXd& U, const Eigen::MatrixXd& x) {
  if (U.cols() == 0) return x;
  return x - U * (U.transpose() * x);
}

struct RefitOptions {
  // Gauss-Newton iterations at most. The model is nearly linear in its coefficients: two or
  // three converge to far below the sigmas, so reaching this means it is not converging (the
  // result says so).
  int max_iterations = 10;
  // Converged when the next step would move no coefficient by more than this many of its
  // sigmas: far below the noise, a further iteration changes nothing a reader can see.
  double tolerance_sigma = 1e-3;

  bool IsValid(std::string* why) const;
};

struct RefitResult {
  Status status = Status::Error("not refitted");  // why not (a refitted value invalid), when !ok
  ExplainState state;
  std::vector<double> sigma;  // per name, 1-sigma (NaN where the data cannot see it)
  double chi2 = 0.0;
  int rank = 0;
  double chi2_per_dof = 1.0;  // chi2 / (rows - rank): the sigmas carry sqrt(max(1, this))
  // Termination: steps taken; converged (the next step below tolerance_sigma) or stopped at
  // max_iterations; the largest move of the step not taken (converged) or of the last step,
  // in sigmas of the coefficient it moves.
  int iterations = 0;
  bool converged = false;
  double last_step_sigma = 0.0;
};

// Gauss-Newton on the named coefficients from start (truncated SVD step on normalised
// columns: directions the data cannot see stay at their start values), until converged or
// max_iterations; the converged step is not taken (it is below tolerance). Sigmas from the
// inverse information at the final state times max(1, chi^2 / dof).
RefitResult refitJointly(ExplainEvaluator* eval, const ExplainState& start,
                         const std::vector<std::string>& names, const RefitOptions& options);

// Chi-square survival function P(X > x) for k degrees of freedom.
double chiSquareSurvival(double x, int k);

}  // namespace imubench::calib
