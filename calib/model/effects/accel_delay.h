// accel_delay: tau_s (s): an accelerometer sample stamped t was taken at t - tau_s relative to
// the gyro sample with the same stamp (gyro-accelerometer asynchrony): the accelerometers
// sense the specific force (and temperature) at the gyro's physics time - tau_s.
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct AccelDelay {
  static constexpr EffectId kId = EffectId::kAccelDelay;
  static constexpr int kTau = 0;  // tau_s, 1

  // Physics time of the accelerometers for the gyros' physics time t_gyro.
  template <typename T>
  static T sampleTime(const T* p, const T& t_gyro) {
    return t_gyro - p[kTau];
  }
};

}  // namespace imubench::calib::model::effects
