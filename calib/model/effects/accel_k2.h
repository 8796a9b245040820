// accel_k2: k2 (per axis, 1/(m/s^2)): the accelerometer axis input u becomes u + k2 u^2,
// u = M f (every linear input term included, before the bias).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct AccelK2 {
  static constexpr EffectId kId = EffectId::kAccelK2;
  static constexpr const char* kName = "accel_k2";
  static constexpr int kK2 = 0;  // k2, 3
  static constexpr std::array<ParamSpec, 1> kParams{{{"k2", ParamShape::kVec3, "1/(m/s^2)"}}};
  static constexpr Stage kStage = Stage::kAxisNonlinear;
  static constexpr const char* kTerm = "u_k += k2_k u_k^2, u = M f";

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    s->u_a += vec3At(p + kK2).cwiseProduct(s->u_a.cwiseProduct(s->u_a));
  }
};

}  // namespace imubench::calib::model::effects
