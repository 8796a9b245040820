// time_delay: tau_s (s): an IMU sample stamped t was taken at t - tau_s (relative to the table
// clock): the physics of both triads is sampled at t - tau_s.
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct TimeDelay {
  static constexpr EffectId kId = EffectId::kTimeDelay;
  static constexpr int kTau = 0;  // tau_s, 1

  // Physics time of a sample stamped t (table clock).
  template <typename T>
  static T sampleTime(const T* p, const T& t_stamp) {
    return t_stamp - p[kTau];
  }
};

}  // namespace imubench::calib::model::effects
