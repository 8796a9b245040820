// The table's geometric error chains (interchange.md), once, templated on the scalar:
//   two-axis:   C_LB = (I+[theta x]) H Rx(outer+o0) (I+[nu x]) Rz(inner+i0) (I+[mu x])
//   three-axis: C_LB = (I+[theta x]) Rz(outer+o0) (I+[nu1 x]) Rx(middle+m0) (I+[nu2 x])
//                      Rz(inner+i0) (I+[mu x])
// C_LB maps body (B) coordinates to the local level frame L (ENU): v_L = C_LB v_B.
// H = Rz(pi/2 - h) for a two-axis table whose outer axis points to heading h (clockwise from
// North; 90 deg = East gives H = I); the base tilt theta is expressed in L, left of H.
//
// Every (I + [t x]) factor is evaluated as the EXACT rotation exp([t x]) (smallRotation in
// calib/model/scalar.h), so C_LB is orthonormal and the kinematics are exact; first_order
// evaluates the interchange chain literally (C_LB then not orthonormal) for comparison.
//
// Angles: encoder readings; the physical joint angle is reading + encoder zero.
#pragma once

#include "calib/model/motion.h"
#include "calib/model/scalar.h"

namespace imubench::calib::model {

// The geometric errors as chain factors see them (rad): theta = base tilt in L (x, y, 0);
// nu1 = the factor after the outer joint (two-axis nu = (0, nu_y, 0); three-axis nu1 =
// (nu1_x, nu1_y, 0)); nu2 = after the middle joint (three-axis (0, nu2_y, 0); zero for a
// two-axis table); mu = mounting (x, y, 0); encoder zeros o0, m0, i0.
template <typename T>
struct ChainErrors {
  Vec3T<T> theta = Vec3T<T>::Zero();
  Vec3T<T> nu1 = Vec3T<T>::Zero();
  Vec3T<T> nu2 = Vec3T<T>::Zero();
  Vec3T<T> mu = Vec3T<T>::Zero();
  T zero_outer = T(0.0);
  T zero_middle = T(0.0);
  T zero_inner = T(0.0);
};

// Parameter blocks of the table errors (rad), with named offsets shared by every estimator.
// Axes block: what the table's own axes get wrong (the navigation-based calibration
// estimates it; the middle entries are not part of a two-axis chain):
inline constexpr int kTiltX = 0;           // base tilt theta_x (L)
inline constexpr int kTiltY = 1;           // base tilt theta_y (L)
inline constexpr int kNonorthInnerY = 2;   // two-axis nu_y; three-axis nu2_y
inline constexpr int kNonorthMiddleX = 3;  // three-axis nu1_x
inline constexpr int kNonorthMiddleY = 4;  // three-axis nu1_y
inline constexpr int kTableAxesSize = 5;
// Device block: the device on the platform and the encoders.
inline constexpr int kMountX = 0;      // mounting mu_x
inline constexpr int kMountY = 1;      // mounting mu_y
inline constexpr int kZeroOuter = 2;   // encoder zero o0
inline constexpr int kZeroMiddle = 3;  // encoder zero m0 (three-axis)
inline constexpr int kZeroInner = 4;   // encoder zero i0
inline constexpr int kTableDeviceSize = 5;

// ChainErrors from the axes block and the device block (nullptr: no mounting, zero encoders).
template <typename T>
ChainErrors<T> chainErrors(TableKind kind, const T* axes, const T* device) {
  const T zero(0.0);
  ChainErrors<T> e;
  e.theta = Vec3T<T>(axes[kTiltX], axes[kTiltY], zero);
  if (kind == TableKind::kTwoAxis) {
    e.nu1 = Vec3T<T>(zero, axes[kNonorthInnerY], zero);
  } else {
    e.nu1 = Vec3T<T>(axes[kNonorthMiddleX], axes[kNonorthMiddleY], zero);
    e.nu2 = Vec3T<T>(zero, axes[kNonorthInnerY], zero);
  }
  if (device) {
    e.mu = Vec3T<T>(device[kMountX], device[kMountY], zero);
    e.zero_outer = device[kZeroOuter];
    e.zero_middle = kind == TableKind::kThreeAxis ? device[kZeroMiddle] : zero;
    e.zero_inner = device[kZeroInner];
  }
  return e;
}

// The constant factors of C_LB = A0 R_outer A1 [R_middle A2] R_inner A3 (A0 includes H), with
// flags for factors that are exactly the identity (skipped in the double hot path).
template <typename T>
struct ChainFactors {
  TableKind kind = TableKind::kTwoAxis;
  Mat3T<T> a0 = Mat3T<T>::Identity();
  Mat3T<T> a1 = Mat3T<T>::Identity();
  Mat3T<T> a2 = Mat3T<T>::Identity();
  Mat3T<T> a3 = Mat3T<T>::Identity();
  bool a0_identity = false, a1_identity = false, a2_identity = false, a3_identity = false;
};

// H of a two-axis table (identity for a three-axis one).
inline Mat3 headingRotation(TableKind kind, double outer_axis_heading_rad) {
  return kind == TableKind::kTwoAxis ? Rz(kPi / 2.0 - outer_axis_heading_rad) : Mat3::Identity();
}

template <typename T>
ChainFactors<T> chainFactors(TableKind kind, double outer_axis_heading_rad, const ChainErrors<T>& e,
                             bool first_order = false) {
  auto small = [first_order](const Vec3T<T>& t) {
    return first_order ? Mat3T<T>(Mat3T<T>::Identity() + skewT(t)) : smallRotation(t);
  };
  ChainFactors<T> f;
  f.kind = kind;
  f.a0 = small(e.theta) * headingRotation(kind, outer_axis_heading_rad).cast<T>();
  f.a1 = small(e.nu1);
  f.a2 = kind == TableKind::kThreeAxis ? small(e.nu2) : Mat3T<T>::Identity();
  f.a3 = small(e.mu);
  f.a0_identity = isExactIdentity(f.a0);
  f.a1_identity = isExactIdentity(f.a1);
  f.a2_identity = isExactIdentity(f.a2);
  f.a3_identity = isExactIdentity(f.a3);
  return f;
}

// Angle, rate and acceleration of one joint (physical angle: encoder reading + zero).
template <typename T>
struct JointState {
  T angle = T(0.0);
  T rate = T(0.0);
  T accel = T(0.0);
};

// C_LB for the PHYSICAL joint angles (middle unused on a two-axis table).
template <typename T>
Mat3T<T> chainAttitude(const ChainFactors<T>& f, const T& outer, const T& middle, const T& inner) {
  using std::cos;
  using std::sin;
  const Mat3T<T> p_inner = rotZTimes(cos(inner), sin(inner), f.a3);
  if (f.kind == TableKind::kTwoAxis) {
    return f.a0 * rotXTimes(cos(outer), sin(outer), Mat3T<T>(f.a1 * p_inner));
  }
  const Mat3T<T> p_middle = rotXTimes(cos(middle), sin(middle), Mat3T<T>(f.a2 * p_inner));
  return f.a0 * rotZTimes(cos(outer), sin(outer), Mat3T<T>(f.a1 * p_middle));
}

// C_LB for ENCODER readings with all errors of e (the interchange.md chain as written above).
template <typename T>
Mat3T<T> tableAttitude(TableKind kind, double outer_axis_heading_rad, const ChainErrors<T>& e,
                       const T& outer, const T& middle, const T& inner) {
  return chainAttitude(chainFactors(kind, outer_axis_heading_rad, e), outer + e.zero_outer,
                       middle + e.zero_middle, inner + e.zero_inner);
}

// Attitude and body kinematics of the platform at one instant.
template <typename T>
struct ChainKinematics {
  Mat3T<T> C_LB = Mat3T<T>::Identity();
  Vec3T<T> w_LB_B = Vec3T<T>::Zero();     // angular rate of B relative to L, in B, rad/s
  Vec3T<T> wdot_LB_B = Vec3T<T>::Zero();  // its time derivative (in B), rad/s^2
};

// C_LB, w_LB_B and wdot_LB_B through the chain for PHYSICAL joint states (sum over joints).
// With P_k the product right of joint k, the body rate is w = sum_k qdot_k u_k with
// u_k = P_k^T e_k, and wdot = sum_k qddot_k u_k + sum_{j<k} qdot_j qdot_k (u_j x u_k).
template <typename T>
ChainKinematics<T> chainKinematics(const ChainFactors<T>& f, const JointState<T>& outer,
                                   const JointState<T>& middle, const JointState<T>& inner) {
  using std::cos;
  using std::sin;
  ChainKinematics<T> k;
  const Vec3T<T> u_inner = f.a3.transpose().col(2);  // A3^T e_z
  const Mat3T<T> p_inner = f.a3_identity ? rotZ(cos(inner.angle), sin(inner.angle))
                                         : rotZTimes(cos(inner.angle), sin(inner.angle), f.a3);
  if (f.kind == TableKind::kTwoAxis) {
    const Mat3T<T> right_of_outer = timesUnlessIdentity(f.a1, f.a1_identity, p_inner);
    const Vec3T<T> u_outer = right_of_outer.row(0).transpose();  // P_outer^T e_x
    k.C_LB = timesUnlessIdentity(f.a0, f.a0_identity,
                                 rotXTimes(cos(outer.angle), sin(outer.angle), right_of_outer));
    k.w_LB_B = outer.rate * u_outer + inner.rate * u_inner;
    k.wdot_LB_B = outer.accel * u_outer + inner.accel * u_inner +
                  outer.rate * inner.rate * u_outer.cross(u_inner);
    return k;
  }
  const Mat3T<T> right_of_middle = timesUnlessIdentity(f.a2, f.a2_identity, p_inner);
  const Vec3T<T> u_middle = right_of_middle.row(0).transpose();
  const Mat3T<T> right_of_outer = timesUnlessIdentity(
      f.a1, f.a1_identity, rotXTimes(cos(middle.angle), sin(middle.angle), right_of_middle));
  const Vec3T<T> u_outer = right_of_outer.row(2).transpose();
  k.C_LB = timesUnlessIdentity(f.a0, f.a0_identity,
                               rotZTimes(cos(outer.angle), sin(outer.angle), right_of_outer));
  k.w_LB_B = outer.rate * u_outer + middle.rate * u_middle + inner.rate * u_inner;
  k.wdot_LB_B = outer.accel * u_outer + middle.accel * u_middle + inner.accel * u_inner +
                outer.rate * middle.rate * u_outer.cross(u_middle) +
                outer.rate * inner.rate * u_outer.cross(u_inner) +
                middle.rate * inner.rate * u_middle.cross(u_inner);
  return k;
}

}  // namespace imubench::calib::model
