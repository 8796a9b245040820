// Exact IMU increments for test trajectories with closed-form truth.
#pragma once

#include <cmath>
#include <sstream>
#include <string>

#include "nav/earth.h"
#include "nav/imu_sample.h"
#include "nav/rotation.h"

namespace imubench::nav::test {

// A body at rest on the Earth with constant attitude C_LB: the gyros see Earth rate, the
// accelerometers the reaction to gravity. Increments over (t - dt, t] are exact (constant
// integrands), plus optional constant sensor biases in B.
struct StationaryTruth {
  Mat3 C_LB = Mat3::Identity();
  double lat_rad = 0.0;
  double height_m = 0.0;
  Vec3 gyro_bias_B = Vec3::Zero();   // rad/s
  Vec3 accel_bias_B = Vec3::Zero();  // m/s^2

  ImuSample sample(double t, double dt) const {
    const Vec3 w_B = C_LB.transpose() * earthRateL(lat_rad) + gyro_bias_B;
    const Vec3 f_B =
        C_LB.transpose() * Vec3(0.0, 0.0, normalGravity(lat_rad, height_m)) + accel_bias_B;
    ImuSample s;
    s.t = t;
    s.dtheta = w_B * dt;
    s.dvel = f_B * dt;
    return s;
  }
};

// int_{t0}^{t1} R(u, -w t) v dt for a unit axis u (Rodrigues):
// R(u, -a) v = v cos a - (u x v) sin a + u (u.v)(1 - cos a).
inline Vec3 integralRotatedBack(const Vec3& u, double w, const Vec3& v, double t0, double t1) {
  const double i_cos = (std::sin(w * t1) - std::sin(w * t0)) / w;   // int cos(w t)
  const double i_sin = -(std::cos(w * t1) - std::cos(w * t0)) / w;  // int sin(w t)
  const double len = t1 - t0;
  return v * i_cos - u.cross(v) * i_sin + u * u.dot(v) * (len - i_cos);
}

// A body turning at constant rate w (rad/s) about an axis u_L fixed on the Earth (a table
// axis through the IMU's centre), starting at C_LB(0) = C0:  C_LB(t) = R(u_L, w t) C0.
// Velocity stays zero. Increments are the exact integrals of w_IB_B and f_B.
struct FixedAxisTurnTruth {
  Mat3 C0 = Mat3::Identity();
  Vec3 u_L = Vec3::UnitX();
  double rate = 0.0;  // rad/s, nonzero
  double lat_rad = 0.0;
  double height_m = 0.0;

  Mat3 C_LB(double t) const { return Eigen::AngleAxisd(rate * t, u_L).toRotationMatrix() * C0; }

  ImuSample sample(double t, double dt) const {
    const double t0 = t - dt;
    // w_IB_B = C_BL(t) w_IE_L + rate u_B, C_BL(t) = C0^T R(u, -w t), u_B = C0^T u_L.
    const Vec3 w_ie = earthRateL(lat_rad);
    const Vec3 up_g(0.0, 0.0, normalGravity(lat_rad, height_m));
    ImuSample s;
    s.t = t;
    s.dtheta = C0.transpose() * (integralRotatedBack(u_L, rate, w_ie, t0, t) + rate * dt * u_L);
    s.dvel = C0.transpose() * integralRotatedBack(u_L, rate, up_g, t0, t);
    return s;
  }
};

// Classical coning w.r.t. inertial space: q_BtoI(t) = (cos(a/2), 0, sin(a/2) cos(W t),
// sin(a/2) sin(W t)); the body x axis cones at half-angle a with frequency W. Body rate:
//   w_IB_B = (-2 W sin^2(a/2), -W sin(a) sin(W t), W sin(a) cos(W t)).
struct ConingTruth {
  double half_angle = 0.0;  // a, rad
  double freq = 0.0;        // W, rad/s

  Quat q_BtoI(double t) const {
    const double c = std::cos(0.5 * half_angle);
    const double s = std::sin(0.5 * half_angle);
    return Quat(c, 0.0, s * std::cos(freq * t), s * std::sin(freq * t));
  }
  Vec3 rate_B(double t) const {
    const double s = std::sin(0.5 * half_angle);
    return {-2.0 * freq * s * s, -freq * std::sin(half_angle) * std::sin(freq * t),
            freq * std::sin(half_angle) * std::cos(freq * t)};
  }
  Vec3 dtheta(double t0, double t1) const {
    const double s = std::sin(0.5 * half_angle);
    return {-2.0 * freq * s * s * (t1 - t0),
            std::sin(half_angle) * (std::cos(freq * t1) - std::cos(freq * t0)),
            std::sin(half_angle) * (std::sin(freq * t1) - std::sin(freq * t0))};
  }
};

// Number for RecordProperty, 6 significant digits.
inline std::string fmt(double x) {
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

// Angle (rad) of the rotation between two attitudes.
inline double attitudeErrorRad(const Quat& q_est, const Quat& q_true) {
  return rotationVectorFromQuat(q_est * q_true.conjugate()).norm();
}

}  // namespace imubench::nav::test
