// The site-stage units (Stage::kSite): the true site the physics runs at, from the assumed one.
//   latitude_error: dlat_rad (rad): true latitude = assumed latitude + dlat_rad (it moves the
//                   Earth rate in L and the normal gravity).
//   gravity_error:  dg_mps2 (m/s^2): true gravity = assumed gravity + dg_mps2 (the assumed one
//                   is the site's, at the true latitude when latitude_error is on too).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

// A site quantity whose true value is the assumed one plus the unit's one parameter.
template <EffectId Id>
struct SiteOffsetUnit {
  static constexpr EffectId kId = Id;
  static constexpr int kDelta = 0;  // dlat_rad or dg_mps2, 1

  template <typename T>
  static T trueValue(const T* p, const T& assumed) {
    return assumed + p[kDelta];
  }
};

using LatitudeError = SiteOffsetUnit<EffectId::kLatitudeError>;
using GravityError = SiteOffsetUnit<EffectId::kGravityError>;

}  // namespace imubench::calib::model::effects
