// gravity_error: dg_mps2 (m/s^2): true gravity = assumed gravity + dg_mps2 (the assumed one is
// the site's, at the true latitude when latitude_error is on too).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct GravityError {
  static constexpr EffectId kId = EffectId::kGravityError;
  static constexpr int kDG = 0;  // dg_mps2, 1

  template <typename T>
  static T gravity(const T* p, const T& assumed_mps2) {
    return assumed_mps2 + p[kDG];
  }
};

}  // namespace imubench::calib::model::effects
