#include "calib/explain_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace imubench::calib {
namespace {

// Relative singular value below which a direction counts as unseen by the data: far above
// the central-difference noise of the columns (~1e-9 relative), far below any real
// conditioning of a calibration (1e-4 .. 1e-6).
constexpr double kRankTolerance = 1e-7;

ExplainState withValue(const ExplainState& state, const std::string& name, double value) {
  ExplainState m = state;
  std::string why;
  setStateValue(&m, name, value, &why);
  return m;
}

}  // namespace

ExplainEvaluator::ExplainEvaluator(const std::vector<ExplainBin>* bins, ExplainForward* forward,
                                   std::vector<double> sigma, double fd_step)
    : bins_(bins), forward_(forward), sigma_(std::move(sigma)), h_(fd_step) {}

std::vector<double> ExplainEvaluator::rawResidual(const ExplainState& state) {
  forward_->predict(state, &pred_);
  std::vector<double> r(pred_.size());
  for (std::size_t b = 0; b < bins_->size(); ++b) {
    for (int c = 0; c < 6; ++c) r[b * 6 + c] = (*bins_)[b].measured[c] - pred_[b * 6 + c];
  }
  return r;
}

Eigen::VectorXd ExplainEvaluator::residual(const ExplainState& state) {
  const std::vector<double> r = rawResidual(state);
  Eigen::VectorXd w(rows());
  for (int i = 0; i < rows(); ++i) w(i) = r[i] / sigma_[i];
  return w;
}

Eigen::MatrixXd ExplainEvaluator::jacobian(const ExplainState& state,
                                           const std::vector<std::string>& names,
                                           std::vector<double>* raw_max) {
  Eigen::MatrixXd J(rows(), static_cast<int>(names.size()));
  if (raw_max) raw_max->assign(names.size(), 0.0);
  for (std::size_t j = 0; j < names.size(); ++j) {
    const double v = stateValue(state, names[j]);
    forward_->predict(withValue(state, names[j], v + h_), &pred_);
    forward_->predict(withValue(state, names[j], v - h_), &pred2_);
    for (int i = 0; i < rows(); ++i) {
      const double d = (pred_[i] - pred2_[i]) / (2.0 * h_);
      J(i, static_cast<int>(j)) = d / sigma_[i];
      if (raw_max) (*raw_max)[j] = std::max((*raw_max)[j], std::abs(d));
    }
  }
  return J;
}

Eigen::MatrixXd columnBasis(const Eigen::MatrixXd& A, double rel_tol) {
  if (A.cols() == 0) return Eigen::MatrixXd(A.rows(), 0);
  Eigen::MatrixXd N = A;
  for (int j = 0; j < N.cols(); ++j) {
    const double n = N.col(j).norm();
    if (n > 0.0) N.col(j) /= n;
  }
  Eigen::BDCSVD<Eigen::MatrixXd> svd(N, Eigen::ComputeThinU);
  const Eigen::VectorXd& s = svd.singularValues();
  int r = 0;
  while (r < s.size() && s(r) > rel_tol * std::max(s(0), 1e-300)) ++r;
  return svd.matrixU().leftCols(r);
}

RefitResult refitJointly(ExplainEvaluator* eval, const ExplainState& start,
                         const std::vector<std::string>& names, int iterations) {
  RefitResult out;
  out.state = start;
  const int n = static_cast<int>(names.size());
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  Eigen::VectorXd d(n);
  Eigen::BDCSVD<Eigen::MatrixXd> svd;
  for (int it = 0; it <= iterations; ++it) {
    r = eval->residual(out.state);
    J = eval->jacobian(out.state, names);
    for (int j = 0; j < n; ++j) {
      d(j) = J.col(j).norm();
      if (d(j) > 0.0) J.col(j) /= d(j);
    }
    svd.compute(J, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& s = svd.singularValues();
    Eigen::VectorXd sinv = Eigen::VectorXd::Zero(s.size());
    out.rank = 0;
    for (int k = 0; k < s.size(); ++k) {
      if (s(k) > kRankTolerance * s(0)) {
        sinv(k) = 1.0 / s(k);
        ++out.rank;
      }
    }
    if (it == iterations) break;
    const Eigen::VectorXd step =
        svd.matrixV() * (sinv.asDiagonal() * (svd.matrixU().transpose() * r));
    for (int j = 0; j < n; ++j) {
      if (d(j) <= 0.0) continue;
      const double v = stateValue(out.state, names[j]) + step(j) / d(j);
      std::string why;
      if (!std::isfinite(v) || !setStateValue(&out.state, names[j], v, &why)) {
        out.status = Status::Error("refit of " + names[j] +
                                   " failed: " + (why.empty() ? "not finite" : why));
        return out;
      }
    }
  }
  out.chi2 = r.squaredNorm();
  const double dof = std::max(1, eval->rows() - out.rank);
  const double scale = std::max(1.0, out.chi2 / dof);
  const Eigen::MatrixXd V = svd.matrixV();
  const Eigen::VectorXd& s = svd.singularValues();
  out.sigma.assign(names.size(), std::numeric_limits<double>::quiet_NaN());
  for (int j = 0; j < n; ++j) {
    if (d(j) <= 0.0) continue;
    double var = 0.0;
    for (int k = 0; k < s.size(); ++k) {
      if (s(k) > kRankTolerance * s(0)) var += V(j, k) * V(j, k) / (s(k) * s(k));
    }
    out.sigma[static_cast<std::size_t>(j)] = std::sqrt(var * scale) / d(j);
  }
  out.status = Status::Ok();
  return out;
}

double chiSquareSurvival(double x, int k) {
  if (x <= 0.0) return 1.0;
  // Q(k) from Q(1) = erfc(sqrt(x/2)) or Q(2) = exp(-x/2) by Q(k+2) = Q(k) + term(k),
  // term(k) = (x/2)^(k/2) exp(-x/2) / Gamma(k/2 + 1).
  int j = k % 2 == 0 ? 2 : 1;
  double q = j == 2 ? std::exp(-0.5 * x) : std::erfc(std::sqrt(0.5 * x));
  for (; j < k; j += 2) {
    const double a = 0.5 * j;
    q += std::exp(a * std::log(0.5 * x) - 0.5 * x - std::lgamma(a + 1.0));
  }
  return std::min(1.0, q);
}

}  // namespace imubench::calib
