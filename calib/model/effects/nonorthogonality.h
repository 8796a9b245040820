// nonorthogonality: inner_y, middle_x, middle_y (rad): the table axes' perpendicularity errors
// (two-axis nu = (0, inner_y, 0); three-axis nu1 = (middle_x, middle_y, 0), nu2 = (0, inner_y,
// 0); the middle entries do not act on a two-axis table), added to the chain's axes block.
#pragma once

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

struct Nonorthogonality {
  static constexpr EffectId kId = EffectId::kNonorthogonality;
  static constexpr int kInnerY = 0;   // inner_y, 1
  static constexpr int kMiddleX = 1;  // middle_x, 1
  static constexpr int kMiddleY = 2;  // middle_y, 1

  template <typename T>
  static void addTo(const T* p, T* axes, T* /*device*/) {
    axes[kNonorthInnerY] += p[kInnerY];
    axes[kNonorthMiddleX] += p[kMiddleX];
    axes[kNonorthMiddleY] += p[kMiddleY];
  }
};

}  // namespace imubench::calib::model::effects
