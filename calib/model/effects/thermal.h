// The temperature units (Stage::kCoefficients): the triads' coefficients at the sensor
// temperature T, both with the parameters k_accel, k_gyro (per axis) and t_ref_c (degC):
//   thermal_bias:  k in m/s^2 per degC (accel), rad/s per degC (gyro):
//                  bias(T) = bias + k (T - t_ref_c)
//   thermal_scale: k in 1/degC:  scale(T) = scale (1 + k (T - t_ref_c))
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

template <EffectId Id>
struct ThermalUnit {
  static_assert(Id == EffectId::kThermalBias || Id == EffectId::kThermalScale);
  static constexpr EffectId kId = Id;
  static constexpr int kAccel = 0;  // k_accel, 3
  static constexpr int kGyro = 3;   // k_gyro, 3
  static constexpr int kTRef = 6;   // t_ref_c, 1

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    const T dT = s->temp_c - p[kTRef];
    const Vec3T<T> d_a = vec3At(p + kAccel) * dT;
    const Vec3T<T> d_g = vec3At(p + kGyro) * dT;
    if constexpr (Id == EffectId::kThermalBias) {
      s->bias_a += d_a;
      s->bias_g += d_g;
    } else {
      s->scale_a = s->scale_a.cwiseProduct(Vec3T<T>::Ones() + d_a);
      s->scale_g = s->scale_g.cwiseProduct(Vec3T<T>::Ones() + d_g);
    }
  }
};

using ThermalBias = ThermalUnit<EffectId::kThermalBias>;
using ThermalScale = ThermalUnit<EffectId::kThermalScale>;

}  // namespace imubench::calib::model::effects
