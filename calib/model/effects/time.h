// The time-stage units (Stage::kTime): the instant at which the physics is sampled.
//   time_delay:  tau_s (s): an IMU sample stamped t was taken at t - tau_s (relative to the
//                table clock): the physics of both triads is sampled at t - tau_s.
//   accel_delay: tau_s (s): an accelerometer sample stamped t was taken at t - tau_s relative
//                to the gyro sample with the same stamp (gyro-accelerometer asynchrony): the
//                accelerometers sense the specific force (and temperature) at the gyros'
//                physics time - tau_s.
// Both delay a time by their parameter; the caller chains them (calib/effects.cpp
// gyroPhysicsTime: the stamp delayed by time_delay; accelPhysicsTime: that further delayed by
// accel_delay).
#pragma once

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

template <EffectId Id>
struct DelayUnit {
  static constexpr EffectId kId = Id;
  static constexpr int kTau = 0;  // tau_s, 1

  // The physics time of a sample whose (stamp or gyro physics) time is t.
  template <typename T>
  static T sampleTime(const T* p, const T& t) {
    return t - p[kTau];
  }
};

using TimeDelay = DelayUnit<EffectId::kTimeDelay>;
using AccelDelay = DelayUnit<EffectId::kAccelDelay>;

}  // namespace imubench::calib::model::effects
