#include "calib/explain/explain_fit.h"

#include <math.h>  // lgamma_r (glibc)

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <thread>

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
                                   std::vector<double> sigma, double fd_step, int threads)
    : bins_(bins),
      forward_(forward),
      sigma_(std::move(sigma)),
      h_(fd_step),
      threads_(std::max(1, threads)) {}

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

void ExplainEvaluator::column(ExplainForward* f, const ExplainState& state, const std::string& name,
                              int j, Eigen::MatrixXd* J, double* raw_max) const {
  std::vector<double> plus, minus;
  const double v = stateValue(state, name);
  f->predict(withValue(state, name, v + h_), &plus);
  f->predict(withValue(state, name, v - h_), &minus);
  *raw_max = 0.0;
  for (int i = 0; i < rows(); ++i) {
    const double d = (plus[i] - minus[i]) / (2.0 * h_);
    (*J)(i, j) = d / sigma_[i];
    *raw_max = std::max(*raw_max, std::abs(d));
  }
}

std::vector<ExplainForward*> ExplainEvaluator::helpers(std::size_t columns) {
  if (!copies_made_ && threads_ > 1 && columns > 1) {
    copies_made_ = true;
    for (int k = 1; k < threads_; ++k) {
      std::unique_ptr<ExplainForward> c = forward_->clone();
      if (!c) break;
      copies_.push_back(std::move(c));
    }
  }
  std::vector<ExplainForward*> out;
  for (const auto& c : copies_) {
    if (out.size() + 1 < columns) out.push_back(c.get());
  }
  return out;
}

Eigen::MatrixXd ExplainEvaluator::jacobian(const ExplainState& state,
                                           const std::vector<std::string>& names,
                                           std::vector<double>* raw_max) {
  Eigen::MatrixXd J(rows(), static_cast<int>(names.size()));
  std::vector<double> raw(names.size(), 0.0);
  // Columns go to whichever thread is free next; each is computed the same way on any.
  std::atomic<std::size_t> next{0};
  auto work = [&](ExplainForward* f) {
    for (std::size_t j = next++; j < names.size(); j = next++) {
      column(f, state, names[j], static_cast<int>(j), &J, &raw[j]);
    }
  };
  const std::vector<ExplainForward*> extra = helpers(names.size());
  std::vector<std::exception_ptr> failed(extra.size());
  std::vector<std::thread> pool;
  for (std::size_t k = 0; k < extra.size(); ++k) {
    pool.emplace_back([&, k] {
      try {
        work(extra[k]);
      } catch (...) {
        failed[k] = std::current_exception();
      }
    });
  }
  work(forward_);
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  if (raw_max) *raw_max = std::move(raw);
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

bool RefitOptions::IsValid(std::string* why) const {
  if (max_iterations >= 1 && tolerance_sigma > 0.0) return true;
  *why = "refit: max_iterations >= 1 and tolerance_sigma > 0";
  return false;
}

namespace {

// One linearisation of the refit: the Jacobian's columns normalised (norms d), its SVD, the
// Gauss-Newton step in normalised units and each coefficient's unscaled variance there.
struct Linearisation {
  Eigen::VectorXd d, step, var;
  int rank = 0;
};

Linearisation linearise(ExplainEvaluator* eval, const ExplainState& state,
                        const std::vector<std::string>& names, Eigen::VectorXd* r) {
  const int n = static_cast<int>(names.size());
  *r = eval->residual(state);
  Eigen::MatrixXd J = eval->jacobian(state, names);
  Linearisation L;
  L.d.resize(n);
  for (int j = 0; j < n; ++j) {
    L.d(j) = J.col(j).norm();
    if (L.d(j) > 0.0) J.col(j) /= L.d(j);
  }
  Eigen::BDCSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  Eigen::VectorXd sinv = Eigen::VectorXd::Zero(s.size());
  for (int k = 0; k < s.size(); ++k) {
    if (s(k) > kRankTolerance * s(0)) {
      sinv(k) = 1.0 / s(k);
      ++L.rank;
    }
  }
  const Eigen::MatrixXd& V = svd.matrixV();
  L.step = V * (sinv.asDiagonal() * (svd.matrixU().transpose() * *r));
  L.var = (V * sinv.asDiagonal()).rowwise().squaredNorm();
  return L;
}

// The largest move of the step, in sigmas of the coefficient it moves.
double stepInSigmas(const Linearisation& L) {
  double m = 0.0;
  for (int j = 0; j < L.step.size(); ++j) {
    if (L.d(j) > 0.0 && L.var(j) > 0.0) m = std::max(m, std::abs(L.step(j)) / std::sqrt(L.var(j)));
  }
  return m;
}

}  // namespace

RefitResult refitJointly(ExplainEvaluator* eval, const ExplainState& start,
                         const std::vector<std::string>& names, const RefitOptions& options) {
  RefitResult out;
  out.state = start;
  std::string why;
  if (!options.IsValid(&why)) {
    out.status = Status::Error(why);
    return out;
  }
  const int n = static_cast<int>(names.size());
  Eigen::VectorXd r;
  Linearisation L;
  for (;;) {
    L = linearise(eval, out.state, names, &r);
    out.last_step_sigma = stepInSigmas(L);
    out.converged = out.last_step_sigma <= options.tolerance_sigma;
    if (out.converged || out.iterations == options.max_iterations) break;
    for (int j = 0; j < n; ++j) {
      if (L.d(j) <= 0.0) continue;
      const double v = stateValue(out.state, names[j]) + L.step(j) / L.d(j);
      if (!std::isfinite(v) || !setStateValue(&out.state, names[j], v, &why)) {
        out.status = Status::Error("refit of " + names[j] +
                                   " failed: " + (why.empty() ? "not finite" : why));
        return out;
      }
    }
    ++out.iterations;
  }
  out.rank = L.rank;
  out.chi2 = r.squaredNorm();
  out.chi2_per_dof = out.chi2 / std::max(1, eval->rows() - out.rank);
  const double scale = std::max(1.0, out.chi2_per_dof);
  out.sigma.assign(names.size(), std::numeric_limits<double>::quiet_NaN());
  for (int j = 0; j < n; ++j) {
    if (L.d(j) > 0.0) out.sigma[static_cast<std::size_t>(j)] = std::sqrt(L.var(j) * scale) / L.d(j);
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
    int sign = 0;  // lgamma_r: lgamma's value without its global sign (thread-safe)
    q += std::exp(a * std::log(0.5 * x) - 0.5 * x - ::lgamma_r(a + 1.0, &sign));
  }
  return std::min(1.0, q);
}

}  // namespace imubench::calib
