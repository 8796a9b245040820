// Scalar-generic building blocks of the forward model: fixed-size vectors and matrices over any
// scalar T (double, or ceres::Jet for automatic differentiation), the skew matrix, the axis
// rotations and the exact small rotation. Conventions (frames, active rotations) are the ones
// nav/rotation.h states once; these are its templated twins.
//
// Math functions are called unqualified after `using std::sin` etc., so ceres::Jet finds its
// own overloads by argument-dependent lookup.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <type_traits>

#include "nav/rotation.h"

namespace imubench::calib::model {

template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3T = Eigen::Matrix<T, 3, 3>;

// [t x]: skewT(t) * v = t x v.
template <typename T>
Mat3T<T> skewT(const Vec3T<T>& t) {
  const T zero(0.0);
  Mat3T<T> s;
  s << zero, -t.z(), t.y(), t.z(), zero, -t.x(), -t.y(), t.x(), zero;
  return s;
}

// Rx(a), Rz(a) from the angle's cosine and sine (active, right-handed; nav/rotation.h).
template <typename T>
Mat3T<T> rotX(const T& c, const T& s) {
  const T zero(0.0), one(1.0);
  Mat3T<T> r;
  r << one, zero, zero, zero, c, -s, zero, s, c;
  return r;
}
template <typename T>
Mat3T<T> rotZ(const T& c, const T& s) {
  const T zero(0.0), one(1.0);
  Mat3T<T> r;
  r << c, -s, zero, s, c, zero, zero, zero, one;
  return r;
}

// Rx(c, s) * m and Rz(c, s) * m without the full product (only two rows mix).
template <typename T>
Mat3T<T> rotXTimes(const T& c, const T& s, const Mat3T<T>& m) {
  Mat3T<T> r;
  r.row(0) = m.row(0);
  r.row(1) = c * m.row(1) - s * m.row(2);
  r.row(2) = s * m.row(1) + c * m.row(2);
  return r;
}
template <typename T>
Mat3T<T> rotZTimes(const T& c, const T& s, const Mat3T<T>& m) {
  Mat3T<T> r;
  r.row(0) = c * m.row(0) - s * m.row(1);
  r.row(1) = s * m.row(0) + c * m.row(1);
  r.row(2) = m.row(2);
  return r;
}

// The exact rotation exp([t x]) by the rotation vector t (Rodrigues). The coefficients
// sin|t|/|t| and (1 - cos|t|)/|t|^2 come from |t|^2 through their series below 1e-4 rad^2, so
// the function is smooth (and differentiable by Jets) at t = 0; the neglected series terms
// are below 1e-24 there.
template <typename T>
Mat3T<T> smallRotation(const Vec3T<T>& t) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T a2 = t.squaredNorm();
  T s, c;  // sin(a)/a, (1 - cos a)/a^2
  if (a2 < T(1e-4)) {
    s = T(1.0) - a2 / T(6.0) + a2 * a2 / T(120.0);
    c = T(0.5) - a2 / T(24.0) + a2 * a2 / T(720.0);
  } else {
    const T a = sqrt(a2);
    s = sin(a) / a;
    c = (T(1.0) - cos(a)) / a2;
  }
  const Mat3T<T> k = skewT(t);
  return Mat3T<T>::Identity() + s * k + c * (k * k);
}

// True when m is exactly the identity (double only; a Jet always counts as general, its
// derivatives are needed). Lets error-free tables skip factors in the hot path.
template <typename T>
bool isExactIdentity(const Mat3T<T>& m) {
  if constexpr (std::is_same_v<T, double>) {
    return m == Mat3::Identity();
  } else {
    return false;
  }
}

// a * m, skipping an identity a.
template <typename T>
Mat3T<T> timesUnlessIdentity(const Mat3T<T>& a, bool a_identity, const Mat3T<T>& m) {
  return a_identity ? m : Mat3T<T>(a * m);
}

}  // namespace imubench::calib::model
