// The reading-stage units: terms the forward pass applies at one instant inside
// sensorReadings (calib/model/effects.h), each `apply(p, ReadingState<T>*)`.
//
// Body input (Stage::kBodyInput), f_B and w_IB_B at the axes' intersection:
//   lever_arm: r_m (m, B) is the position of the accelerometer triad's sensing point relative
//     to the intersection of the table axes; the specific force there is
//       f += w' x r + w x (w x r),  w = w_LB_B (table rate in B), w' its derivative.
//     (The gyro g-sensitivity term reads this f.)
//   gyro_g_sensitivity: G (3x3, row-major, rad/s per m/s^2): the gyro input gains G f,
//       w_IB_B += G f,  f = the specific force the accelerometer triad senses (lever arm
//     included).
// Axis input (Stage::kAxisInput), u = M f per axis:
//   size_effect: d_y_m, d_z_m (m, B): positions of the y and z accelerometers' sensing points
//     relative to the x accelerometer's (whose point is lever_arm.r_m, the axes' intersection
//     without a lever arm). Axis k senses the specific force at its own point; the lever-arm
//     term is linear in the position, so relative to the x point
//       u_y += M_y . (w' x d_y + w x (w x d_y)),  u_z += M_z . (w' x d_z + w x (w x d_z)),
//     M_k the accelerometer misalignment row of axis k, w = w_LB_B.
// Axis nonlinearity (Stage::kAxisNonlinear):
//   accel_k2: k2 (per axis, 1/(m/s^2)): the accelerometer axis input u becomes u + k2 u^2,
//     u = M f (every linear input term included, before the bias).
// Reading (Stage::kReading):
//   scale_asymmetry: gyro (per axis, dimensionless): half the difference of the scale for
//     positive and negative rate. The gyro scale is s + a for u > 0 and s - a for u < 0, i.e.
//       gyro_k += a_k |u_k|,  u = M w - bias (the axis input after the bias).
//     |u| is not differentiable at u = 0; ceres::Jet's abs takes the sign of u there.
#pragma once

#include <cmath>

#include "calib/model/bench_physics.h"
#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct LeverArm {
  static constexpr EffectId kId = EffectId::kLeverArm;
  static constexpr int kR = 0;  // r_m, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    s->f_B += leverArmTerm(s->w_LB_B, s->wdot_LB_B, vec3At(p + kR));
  }
};

struct GyroGSensitivity {
  static constexpr EffectId kId = EffectId::kGyroGSensitivity;
  static constexpr int kG = 0;  // G, 9, row-major

  template <typename T>
  static Vec3T<T> rateTerm(const T* p, const Vec3T<T>& f_B) {
    Mat3T<T> G;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) G(r, c) = p[kG + 3 * r + c];
    }
    return G * f_B;
  }
  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    s->w_IB_B += rateTerm(p, s->f_B);
  }
};

struct SizeEffect {
  static constexpr EffectId kId = EffectId::kSizeEffect;
  static constexpr int kDY = 0;  // d_y_m, 3
  static constexpr int kDZ = 3;  // d_z_m, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    const Vec3T<T> f_y = leverArmTerm(s->w_LB_B, s->wdot_LB_B, vec3At(p + kDY));
    const Vec3T<T> f_z = leverArmTerm(s->w_LB_B, s->wdot_LB_B, vec3At(p + kDZ));
    s->u_a[1] += (s->M_a.row(1) * f_y)(0);
    s->u_a[2] += (s->M_a.row(2) * f_z)(0);
  }
};

struct AccelK2 {
  static constexpr EffectId kId = EffectId::kAccelK2;
  static constexpr int kK2 = 0;  // k2, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    s->u_a += vec3At(p + kK2).cwiseProduct(s->u_a.cwiseProduct(s->u_a));
  }
};

struct ScaleAsymmetry {
  static constexpr EffectId kId = EffectId::kScaleAsymmetry;
  static constexpr int kGyro = 0;  // gyro, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    using std::abs;
    for (int k = 0; k < 3; ++k) s->gyro[k] += p[kGyro + k] * abs(s->u_g[k]);
  }
};

}  // namespace imubench::calib::model::effects
