// Jacobians of a scalar-generic function by ceres::Jet and by central differences of the same
// function in double, and the check that they agree (tests of the templated forward model).
#pragma once

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <vector>

#include "calib/model/scalar.h"

namespace imubench::calib::model {

// Jacobian of f (a generic callable: const T* -> std::vector<T>) at x by Jets of size N.
template <int N, class F>
Eigen::MatrixXd jetJacobian(const F& f, const std::vector<double>& x) {
  using Jet = ceres::Jet<double, N>;
  EXPECT_LE(x.size(), static_cast<std::size_t>(N));
  std::vector<Jet> xj(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) xj[k] = Jet(x[k], static_cast<int>(k));
  const std::vector<Jet> y = f(xj.data());
  Eigen::MatrixXd J(static_cast<Eigen::Index>(y.size()), static_cast<Eigen::Index>(x.size()));
  for (std::size_t r = 0; r < y.size(); ++r) {
    J.row(static_cast<Eigen::Index>(r)) =
        y[r].v.head(static_cast<Eigen::Index>(x.size())).transpose();
  }
  return J;
}

// The same by central differences of f in double.
template <class F>
Eigen::MatrixXd centralDifferences(const F& f, const std::vector<double>& x, double h) {
  const std::size_t m = f(x.data()).size();
  Eigen::MatrixXd J(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(x.size()));
  for (std::size_t k = 0; k < x.size(); ++k) {
    std::vector<double> xp = x, xm = x;
    xp[k] += h;
    xm[k] -= h;
    const std::vector<double> yp = f(xp.data()), ym = f(xm.data());
    for (std::size_t r = 0; r < m; ++r) {
      J(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(k)) = (yp[r] - ym[r]) / (2.0 * h);
    }
  }
  return J;
}

// Jets agree with central differences (step 1e-6) to tol, and the first `exercised` columns
// are not zero (no parameter silently dropped from the model).
template <int N, class F>
void expectJetMatchesDifferences(const F& f, const std::vector<double>& x, double tol,
                                 int exercised) {
  const Eigen::MatrixXd Jj = jetJacobian<N>(f, x);
  const Eigen::MatrixXd Jf = centralDifferences(f, x, 1e-6);
  ASSERT_EQ(Jj.rows(), Jf.rows());
  for (Eigen::Index k = 0; k < exercised && k < Jj.cols(); ++k) {
    EXPECT_GT(Jj.col(k).norm(), 1e-9) << "parameter " << k << " has no effect";
  }
  EXPECT_LT((Jj - Jf).cwiseAbs().maxCoeff(), tol) << "jet:\n" << Jj << "\nfd:\n" << Jf;
}

// Appends a vector's entries, or a matrix's column-major, to a function's output.
template <typename T>
void append(std::vector<T>* out, const Vec3T<T>& v) {
  for (int i = 0; i < 3; ++i) out->push_back(v[i]);
}
template <typename T>
void append(std::vector<T>* out, const Mat3T<T>& m) {
  for (int i = 0; i < 9; ++i) out->push_back(m(i % 3, i / 3));
}

}  // namespace imubench::calib::model
