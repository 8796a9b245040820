#include "calib/observability.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace imubench::calib {

bool InformationOptions::IsValid(std::string* why) const {
  if (!(rel_tol > 0.0 && rel_tol < 1.0)) {
    if (why) *why = "rel_tol must be in (0, 1)";
    return false;
  }
  if (!(show_component >= 0.0 && show_component < 1.0)) {
    if (why) *why = "show_component must be in [0, 1)";
    return false;
  }
  return true;
}

std::string describeDirection(const Eigen::VectorXd& v, const std::vector<std::string>& names,
                              double show_component) {
  std::vector<int> order;
  for (int k = 0; k < v.size(); ++k)
    if (std::abs(v(k)) >= show_component) order.push_back(k);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return std::abs(v(a)) > std::abs(v(b)); });
  // Sign convention: the largest component positive.
  const double sign = !order.empty() && v(order.front()) < 0.0 ? -1.0 : 1.0;
  std::ostringstream names_out, coef_out;
  coef_out << std::fixed << std::setprecision(2);
  for (std::size_t i = 0; i < order.size(); ++i) {
    names_out << (i ? " + " : "") << names[static_cast<std::size_t>(order[i])];
    coef_out << (i ? ", " : "") << sign * v(order[i]);
  }
  return names_out.str() + " (" + coef_out.str() + ")";
}

InformationAnalysis analyseInformation(const Eigen::MatrixXd& J,
                                       const std::vector<std::string>& names,
                                       const InformationOptions& options) {
  InformationAnalysis a;
  a.names = names;
  std::string why;
  if (!options.IsValid(&why)) {
    a.ok = false;
    a.reason = why;
    return a;
  }
  if (static_cast<std::size_t>(J.cols()) != names.size() || J.cols() == 0) {
    a.ok = false;
    a.reason = "Jacobian has " + std::to_string(J.cols()) + " columns for " +
               std::to_string(names.size()) + " parameter names";
    return a;
  }
  const Eigen::Index p = J.cols();
  a.column_scale = J.colwise().norm().transpose();
  Eigen::MatrixXd Jn = J;
  for (Eigen::Index k = 0; k < p; ++k)
    if (a.column_scale(k) > 0.0) Jn.col(k) /= a.column_scale(k);
  a.fisher = Jn.transpose() * Jn;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a.fisher);
  a.eigenvalues = es.eigenvalues();
  a.eigenvectors = es.eigenvectors();
  const double lmax = std::max(a.eigenvalues.maxCoeff(), 0.0);
  const double thr = options.rel_tol * lmax;
  a.observable.assign(static_cast<std::size_t>(p), true);
  double lmin_ok = lmax;
  for (Eigen::Index k = 0; k < p; ++k) {
    const double l = a.eigenvalues(k);
    if (l > thr) {
      lmin_ok = std::min(lmin_ok, l);
      continue;
    }
    NullDirection d;
    d.eigenvalue = l;
    d.vector = a.eigenvectors.col(k);
    d.description = describeDirection(d.vector, names, options.show_component);
    for (Eigen::Index i = 0; i < p; ++i)
      if (std::abs(d.vector(i)) >= options.show_component)
        a.observable[static_cast<std::size_t>(i)] = false;
    a.null_directions.push_back(std::move(d));
  }
  a.condition = lmin_ok > 0.0 ? lmax / lmin_ok : std::numeric_limits<double>::infinity();
  return a;
}

}  // namespace imubench::calib
