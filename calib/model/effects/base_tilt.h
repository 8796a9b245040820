// base_tilt: x, y (rad): the table base's levelling error theta = (x, y, 0) in L, added to the
// table chain's axes block (calib/model/table_chain.h kTiltX, kTiltY) before the kinematics.
#pragma once

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

struct BaseTilt {
  static constexpr EffectId kId = EffectId::kBaseTilt;
  static constexpr int kX = 0;  // x, 1
  static constexpr int kY = 1;  // y, 1

  // Adds the errors to the chain's axes and device blocks (kTableAxesSize, kTableDeviceSize).
  template <typename T>
  static void addTo(const T* p, T* axes, T* /*device*/) {
    axes[kTiltX] += p[kX];
    axes[kTiltY] += p[kY];
  }
};

}  // namespace imubench::calib::model::effects
