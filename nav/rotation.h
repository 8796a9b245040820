// Rotation conventions for all of imubench. This is the one header that states them.
//
// Frames
//   L  local level frame, ENU: x East, y North, z Up (the seed paper writes N, Up, E).
//   B  body frame: the IMU's model orthogonal instrument frame.
//   I  inertial frame (used only through rates: w_IB = rate of B w.r.t. inertial space).
//
// Naming
//   C_LB     direction-cosine matrix mapping body coordinates to local: v_L = C_LB * v_B.
//   q_BtoL   the same rotation as a unit quaternion (Rodrigues-Hamilton parameters,
//            Hamilton product, Eigen::Quaterniond): v_L = q_BtoL * v_B.
//   w_IB_B   angular rate of B w.r.t. I, resolved in B.  p_IinG style: "what, in which frame".
//
// Active rotations
//   Rx(a), Ry(a), Rz(a) rotate a vector right-handedly by angle a about the named axis
//   (Rz(a) * e_x = (cos a, sin a, 0)). [t x] is the skew matrix: skew(t) * v = t.cross(v).
//   A small rotation by the vector t is I + [t x] to first order.
//
// Units: SI inside (rad, rad/s, m/s, m/s^2, m, s). Degrees and arcseconds appear only at the
// edges (files, reports, CLI), converted with the constants below.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <numbers>

namespace imubench {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;
inline constexpr double kArcsecToRad = kDegToRad / 3600.0;
inline constexpr double kRadToArcsec = 1.0 / kArcsecToRad;
inline constexpr double kDegPerHourToRadPerSec = kDegToRad / 3600.0;
inline constexpr double kMicroGToMps2 = 9.80665e-6;  // 1 ug (standard gravity), m/s^2

inline Mat3 skew(const Vec3& t) {
  Mat3 s;
  s << 0.0, -t.z(), t.y(), t.z(), 0.0, -t.x(), -t.y(), t.x(), 0.0;
  return s;
}

inline Mat3 Rx(double a) {
  return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix();
}
inline Mat3 Ry(double a) {
  return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix();
}
inline Mat3 Rz(double a) {
  return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix();
}

// Quaternion of the rotation by the rotation vector phi (angle |phi| about phi/|phi|).
// Exact for any angle; uses a series near zero so it stays accurate for tiny increments.
inline Quat quatFromRotationVector(const Vec3& phi) {
  const double a2 = phi.squaredNorm();
  double s = 0.0;  // sin(|phi|/2)/|phi|
  double c = 0.0;  // cos(|phi|/2)
  if (a2 < 1e-8) {
    s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0;
    c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0;
  } else {
    const double a = std::sqrt(a2);
    s = std::sin(0.5 * a) / a;
    c = std::cos(0.5 * a);
  }
  return Quat(c, s * phi.x(), s * phi.y(), s * phi.z());
}

// Inverse of quatFromRotationVector, angle in [0, pi].
inline Vec3 rotationVectorFromQuat(const Quat& q_in) {
  Quat q = q_in.w() < 0.0 ? Quat(-q_in.w(), -q_in.x(), -q_in.y(), -q_in.z()) : q_in;
  const double sn = q.vec().norm();
  if (sn < 1e-12) return 2.0 * q.vec() / q.w();
  const double angle = 2.0 * std::atan2(sn, q.w());
  return q.vec() * (angle / sn);
}

}  // namespace imubench
