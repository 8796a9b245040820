// lever_arm: r_m (m, B) is the position of the accelerometer triad's sensing point relative to
// the intersection of the table axes; the specific force there is
//   f += w' x r + w x (w x r),  w = w_LB_B (table rate in B), w' its derivative.
// (The gyro g-sensitivity term reads this f.)
#pragma once

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

}  // namespace imubench::calib::model::effects
