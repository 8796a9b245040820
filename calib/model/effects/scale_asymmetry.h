// scale_asymmetry: gyro (per axis, dimensionless): half the difference of the scale for
// positive and negative rate. The gyro scale is s + a for u > 0 and s - a for u < 0, i.e.
//   gyro_k += a_k |u_k|,  u = M w - bias (the axis input after the bias).
// |u| is not differentiable at u = 0; ceres::Jet's abs takes the sign of u there.
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct ScaleAsymmetry {
  static constexpr EffectId kId = EffectId::kScaleAsymmetry;
  static constexpr int kGyro = 0;  // gyro, 3

  template <typename T>
  static void apply(const T* p, ReadingState<T>* s) {
    using std::abs;
    for (int k = 0; k < 3; ++k) s->gyro[k] += p[kGyro + k] * abs(s->u_g[k]);
  }
};

}  // namespace imubench::calib::model::effects
