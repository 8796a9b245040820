// thermal_bias: k_accel (m/s^2 per degC), k_gyro (rad/s per degC) per axis, t_ref_c (degC):
//   bias(T) = bias + k (T - t_ref_c)   for both triads, T the sensor temperature.
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct ThermalBias {
  static constexpr EffectId kId = EffectId::kThermalBias;
  static constexpr int kAccel = 0;  // k_accel, 3
  static constexpr int kGyro = 3;   // k_gyro, 3
  static constexpr int kTRef = 6;   // t_ref_c, 1

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    const T dT = s->temp_c - p[kTRef];
    s->bias_a += vec3At(p + kAccel) * dT;
    s->bias_g += vec3At(p + kGyro) * dT;
  }
};

}  // namespace imubench::calib::model::effects
