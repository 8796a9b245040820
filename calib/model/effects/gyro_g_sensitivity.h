// gyro_g_sensitivity: G (3x3, row-major, rad/s per m/s^2): the gyro input gains G f,
//   w_IB_B += G f,  f = the specific force the accelerometer triad senses (lever arm included).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

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

}  // namespace imubench::calib::model::effects
