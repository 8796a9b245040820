// The sensor equation of one triad (interchange.md, the seed paper's eq. 1), once:
//     reading = diag(scale) * (M * input - bias),
//     M = [[1, m_xy, -m_xz], [-m_yx, 1, m_yz], [m_zx, -m_zy, 1]],
// its exact inverse (compensation) input = M^-1 (diag(scale)^-1 reading + bias), templated on
// the scalar so Ceres can differentiate it.
// input: specific force (m/s^2, accelerometers) or angular rate w.r.t. inertial space (rad/s,
// gyros), both in the body frame B; reading in the same units (rates, not increments).
//
// Parameter block of one triad (Ceres style: one array of kTriadSize scalars), with NAMED
// offsets shared by every estimator (never literal indices):
//   [kScale .. +3)  total scale factor per axis (about 1.0)
//   [kBias  .. +3)  bias per axis, subtracted before scaling (m/s^2 or rad/s)
//   [kMis   .. +6)  misalignments in kMisEntries order: xy, xz, yx, yz, zx, zy (rad)
#pragma once

#include <array>

#include "calib/model/scalar.h"

namespace imubench::calib::model {

inline constexpr int kScale = 0;
inline constexpr int kBias = 3;
inline constexpr int kMis = 6;
inline constexpr int kTriadSize = 12;

// Order of the misalignments after kMis.
inline constexpr int kMisXY = 0;
inline constexpr int kMisXZ = 1;
inline constexpr int kMisYX = 2;
inline constexpr int kMisYZ = 3;
inline constexpr int kMisZX = 4;
inline constexpr int kMisZY = 5;
inline constexpr int kMisCount = 6;

// Where each misalignment stands in M and with which sign: M(row, col) = sign * m. This table
// is the one statement of eq. (1)'s sign pattern; M, its inverse mapping and every estimator's
// naming of gain-matrix entries read it.
struct MisalignmentEntry {
  const char* name;  // interchange.md JSON key
  int row;
  int col;
  double sign;
};
inline constexpr std::array<MisalignmentEntry, kMisCount> kMisEntries{{
    {"xy", 0, 1, 1.0},
    {"xz", 0, 2, -1.0},
    {"yx", 1, 0, -1.0},
    {"yz", 1, 2, 1.0},
    {"zx", 2, 0, 1.0},
    {"zy", 2, 1, -1.0},
}};

// Index (0..5, kMisEntries order) of the misalignment at M(row, col), row != col.
constexpr int misalignmentAt(int row, int col) {
  for (int k = 0; k < kMisCount; ++k) {
    if (kMisEntries[static_cast<std::size_t>(k)].row == row &&
        kMisEntries[static_cast<std::size_t>(k)].col == col) {
      return k;
    }
  }
  return -1;
}

// M of eq. (1) from the six misalignments (kMisEntries order).
template <typename T>
Mat3T<T> misalignmentMatrix(const T* mis) {
  Mat3T<T> M = Mat3T<T>::Identity();
  for (int k = 0; k < kMisCount; ++k) {
    const MisalignmentEntry& e = kMisEntries[static_cast<std::size_t>(k)];
    M(e.row, e.col) = T(e.sign) * mis[k];
  }
  return M;
}

// The six misalignments of a matrix with unit diagonal (inverse of misalignmentMatrix).
inline std::array<double, kMisCount> misalignmentsOf(const Mat3& M) {
  std::array<double, kMisCount> m{};
  for (int k = 0; k < kMisCount; ++k) {
    const MisalignmentEntry& e = kMisEntries[static_cast<std::size_t>(k)];
    m[static_cast<std::size_t>(k)] = e.sign * M(e.row, e.col);
  }
  return m;
}

template <typename T>
Vec3T<T> scaleOf(const T* triad) {
  return Vec3T<T>(triad[kScale], triad[kScale + 1], triad[kScale + 2]);
}
template <typename T>
Vec3T<T> biasOf(const T* triad) {
  return Vec3T<T>(triad[kBias], triad[kBias + 1], triad[kBias + 2]);
}

// Noise-free reading for an input: diag(scale) (M input - bias).
template <typename T>
Vec3T<T> reading(const T* triad, const Vec3T<T>& input) {
  return scaleOf(triad).cwiseProduct(misalignmentMatrix(triad + kMis) * input - biasOf(triad));
}

// Compensation is affine in the reading: input = G reading + h, G = M^-1 diag(scale)^-1,
// h = M^-1 bias (the exact inverse of reading(); M is near identity, never singular for
// physical misalignments).
template <typename T>
void compensationAffine(const T* triad, Mat3T<T>* G, Vec3T<T>* h) {
  const Mat3T<T> Minv = misalignmentMatrix(triad + kMis).inverse();
  Mat3T<T> Sinv = Mat3T<T>::Zero();
  for (int i = 0; i < 3; ++i) Sinv(i, i) = T(1.0) / triad[kScale + i];
  *G = Minv * Sinv;
  *h = Minv * biasOf(triad);
}

// The input that produces this reading: the exact inverse of reading().
template <typename T>
Vec3T<T> input(const T* triad, const Vec3T<T>& reading_value) {
  Mat3T<T> G;
  Vec3T<T> h;
  compensationAffine(triad, &G, &h);
  return G * reading_value + h;
}

}  // namespace imubench::calib::model
