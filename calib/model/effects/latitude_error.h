// latitude_error: dlat_rad (rad): true latitude = assumed latitude + dlat_rad (it moves the
// Earth rate in L and the normal gravity).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct LatitudeError {
  static constexpr EffectId kId = EffectId::kLatitudeError;
  static constexpr int kDLat = 0;  // dlat_rad, 1

  template <typename T>
  static T latitude(const T* p, const T& assumed_rad) {
    return assumed_rad + p[kDLat];
  }
};

}  // namespace imubench::calib::model::effects
