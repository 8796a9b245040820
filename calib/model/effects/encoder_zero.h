// encoder_zero: outer, middle, inner (rad): encoder zero errors (physical angle = encoder
// reading + zero; middle only on a three-axis table), added to the chain's device block.
#pragma once

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

struct EncoderZero {
  static constexpr EffectId kId = EffectId::kEncoderZero;
  static constexpr int kOuter = 0;   // outer, 1
  static constexpr int kMiddle = 1;  // middle, 1
  static constexpr int kInner = 2;   // inner, 1

  template <typename T>
  static void addTo(const T* p, T* /*axes*/, T* device) {
    device[kZeroOuter] += p[kOuter];
    device[kZeroMiddle] += p[kMiddle];
    device[kZeroInner] += p[kInner];
  }
};

}  // namespace imubench::calib::model::effects
