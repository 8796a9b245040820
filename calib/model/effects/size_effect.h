// size_effect: d_y_m, d_z_m (m, B): positions of the y and z accelerometers' sensing points
// relative to the x accelerometer's (whose point is lever_arm.r_m, the axes' intersection
// without a lever arm). Axis k senses the specific force at its own point; the lever-arm term
// is linear in the position, so relative to the x point
//   u_y += M_y . (w' x d_y + w x (w x d_y)),  u_z += M_z . (w' x d_z + w x (w x d_z)),
// M_k the accelerometer misalignment row of axis k, w = w_LB_B.
#pragma once

#include "calib/model/bench_physics.h"
#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

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

}  // namespace imubench::calib::model::effects
