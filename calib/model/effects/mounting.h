// mounting: x, y (rad): the device's installation error on the platform mu = (x, y, 0), added
// to the chain's device block (kMountX, kMountY).
#pragma once

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

struct Mounting {
  static constexpr EffectId kId = EffectId::kMounting;
  static constexpr int kX = 0;  // x, 1
  static constexpr int kY = 1;  // y, 1

  template <typename T>
  static void addTo(const T* p, T* /*axes*/, T* device) {
    device[kMountX] += p[kX];
    device[kMountY] += p[kY];
  }
};

}  // namespace imubench::calib::model::effects
