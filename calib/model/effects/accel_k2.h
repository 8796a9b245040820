// accel_k2: k2 (per axis, 1/(m/s^2)): the accelerometer axis input u becomes u + k2 u^2,
// u = M f (every linear input term included, before the bias).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct AccelK2 {
  static constexpr EffectId kId = EffectId::kAccelK2;
  static constexpr int kK2 = 0;  // k2, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    s->u_a += vec3At(p + kK2).cwiseProduct(s->u_a.cwiseProduct(s->u_a));
  }
};

}  // namespace imubench::calib::model::effects
