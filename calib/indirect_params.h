// Parameter layout of the navigation-based (indirect) calibration and the templated sensor
// compensation shared by its cost functions.
//
// Each triad is one Ceres parameter block of kTriadSize doubles with NAMED offsets (never
// magic indices): scale (3), bias (3), misalignment (6: xy, xz, yx, yz, zx, zy) in the
// interchange.md eq. (1) form
//     reading = diag(scale) * (M * input - bias),
//     M = [[1, m_xy, -m_xz], [-m_yx, 1, m_yz], [m_zx, -m_zy, 1]].
// The table block holds the base tilt (theta_x, theta_y) in rad.
//
// Frame: the "input" here is resolved in the gyro-referenced platform frame P (see
// docs/calibration.md): the frame the table's orthogonal axes define, so the estimated
// misalignments of BOTH triads absorb the device mounting on the platform in one definite way.
#pragma once

#include <array>
#include <string>

#include "calib/table_model.h"
#include "nav/rotation.h"

namespace imubench::calib::indirect {

// Offsets inside a triad block.
inline constexpr int kScale = 0;  // 3 total scale factors (~1.0)
inline constexpr int kBias = 3;   // 3 biases (m/s^2 or rad/s)
inline constexpr int kMis = 6;    // 6 misalignments, order below
inline constexpr int kTriadSize = 12;
// Order of the misalignment entries after kMis.
inline constexpr int kMisXY = 0;
inline constexpr int kMisXZ = 1;
inline constexpr int kMisYX = 2;
inline constexpr int kMisYZ = 3;
inline constexpr int kMisZX = 4;
inline constexpr int kMisZY = 5;
inline constexpr std::array<const char*, 6> kMisNames{"xy", "xz", "yx", "yz", "zx", "zy"};

// Offsets inside the table block (rad): base tilt theta in L, and the axis nonorthogonality
// of interchange.md: two-axis nu = (0, inner_y, 0); three-axis nu1 = (middle_x, middle_y, 0),
// nu2 = (0, inner_y, 0). The middle entries are not part of a two-axis table's chain.
inline constexpr int kTiltX = 0;
inline constexpr int kTiltY = 1;
inline constexpr int kNonorthInnerY = 2;
inline constexpr int kNonorthMiddleX = 3;
inline constexpr int kNonorthMiddleY = 4;
inline constexpr int kTableSize = 5;

// Total parameter count and the global index helpers used for naming (information matrix,
// covariance, observability flags): [accel block | gyro block | table block].
inline constexpr int kAccelOffset = 0;
inline constexpr int kGyroOffset = kTriadSize;
inline constexpr int kTableOffset = 2 * kTriadSize;
inline constexpr int kParamCount = 2 * kTriadSize + kTableSize;

// "accel.scale.x", "gyro.misalignment.zy", "table.base_tilt.y", ...
std::string parameterName(int global_index);

template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3T = Eigen::Matrix<T, 3, 3>;

// M of eq. (1) from a triad block.
template <typename T>
Mat3T<T> misalignmentMatrix(const T* triad) {
  const T* m = triad + kMis;
  const T one(1.0);
  Mat3T<T> M;
  M << one, m[kMisXY], -m[kMisXZ], -m[kMisYX], one, m[kMisYZ], m[kMisZX], -m[kMisZY], one;
  return M;
}

// I + [v x] (first order: the table errors are tens of arcsec, the neglected second-order
// term is below 1e-7 rad).
template <typename T>
Mat3T<T> smallRotation(const T& x, const T& y, const T& z) {
  const T one(1.0);
  Mat3T<T> R;
  R << one, -z, y, z, one, -x, -y, x, one;
  return R;
}

// Attitude C_LP of the platform frame P (the inner gimbal: z = the inner axis) for the encoder
// angles, with the base tilt and nonorthogonality of the table block — the interchange.md chain
// without the mounting and with the encoder zeros absorbed (the outer zero of a two-axis table
// into the tilt, the inner zero into the frame P, the three-axis middle zero into middle_x):
//   two-axis:   (I + [theta x]) H Rx(outer) (I + [nu x]) Rz(inner)
//   three-axis: (I + [theta x]) Rz(outer) (I + [nu1 x]) Rx(middle) (I + [nu2 x]) Rz(inner)
template <typename T>
Mat3T<T> platformAttitude(const TableGeometry& g, const TableAngles& a, const T* table) {
  const T zero(0.0);
  const Mat3T<T> tilt = smallRotation(table[kTiltX], table[kTiltY], zero);
  const Mat3T<T> inner = Rz(a.inner).cast<T>();
  if (g.kind == TableKind::kTwoAxis) {
    const Mat3 HRx = Rz(kPi / 2.0 - g.outer_axis_heading_rad) * Rx(a.outer);
    return tilt * HRx.cast<T>() * smallRotation(zero, table[kNonorthInnerY], zero) * inner;
  }
  return tilt * Rz(a.outer).cast<T>() *
         smallRotation(table[kNonorthMiddleX], table[kNonorthMiddleY], zero) *
         Rx(a.middle).cast<T>() * smallRotation(zero, table[kNonorthInnerY], zero) * inner;
}

// Compensation is affine in the reading: input = G * reading + h with
// G = M^-1 diag(scale)^-1 and h = M^-1 bias (exact inverse of eq. (1), noise aside).
template <typename T>
void compensationAffine(const T* triad, Mat3T<T>* G, Vec3T<T>* h) {
  const Mat3T<T> Minv = misalignmentMatrix(triad).inverse();
  Mat3T<T> Sinv = Mat3T<T>::Zero();
  for (int i = 0; i < 3; ++i) Sinv(i, i) = T(1.0) / triad[kScale + i];
  *G = Minv * Sinv;
  const Vec3T<T> b(triad[kBias], triad[kBias + 1], triad[kBias + 2]);
  *h = Minv * b;
}

// input = M^-1 (diag(scale)^-1 reading + bias).
template <typename T>
Vec3T<T> compensate(const T* triad, const Vec3& reading) {
  Mat3T<T> G;
  Vec3T<T> h;
  compensationAffine(triad, &G, &h);
  return G * reading.cast<T>() + h;
}

}  // namespace imubench::calib::indirect
