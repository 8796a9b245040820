// thermal_scale: k_accel, k_gyro (1/degC) per axis, t_ref_c (degC):
//   scale(T) = scale (1 + k (T - t_ref_c))   for both triads, T the sensor temperature.
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct ThermalScale {
  static constexpr EffectId kId = EffectId::kThermalScale;
  static constexpr int kAccel = 0;  // k_accel, 3
  static constexpr int kGyro = 3;   // k_gyro, 3
  static constexpr int kTRef = 6;   // t_ref_c, 1

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    const T dT = s->temp_c - p[kTRef];
    s->scale_a = s->scale_a.cwiseProduct(Vec3T<T>::Ones() + vec3At(p + kAccel) * dT);
    s->scale_g = s->scale_g.cwiseProduct(Vec3T<T>::Ones() + vec3At(p + kGyro) * dT);
  }
};

}  // namespace imubench::calib::model::effects
