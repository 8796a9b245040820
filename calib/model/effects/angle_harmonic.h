// angle_harmonic: axis (outer | middle | inner), order k (integer >= 1), cos_rad, sin_rad (rad):
// the true angle of that table axis is the encoder angle a + c cos(k a) + s sin(k a) (encoder
// and bearing errors periodic in the angle). Rate and acceleration follow by the chain rule:
//   e(a) = c cos(ka) + s sin(ka),  e' = k (s cos(ka) - c sin(ka)),  e'' = -k^2 e(a)
//   angle += e,  rate += e' a_dot,  accel += e' a_ddot + e'' a_dot^2.
// The physical joint angle then adds the encoder zero in the chain (calib/model/table_chain.h).
#pragma once

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

struct AngleHarmonic {
  static constexpr EffectId kId = EffectId::kAngleHarmonic;
  static constexpr int kAxis = 0;   // axis, 1 (kTableAxisOuter / Middle / Inner)
  static constexpr int kOrder = 1;  // order, 1
  static constexpr int kCos = 2;    // cos_rad, 1
  static constexpr int kSin = 3;    // sin_rad, 1

  // The true joint state of the axis from its encoder angle, rate and acceleration (the
  // caller picks the axis by p[kAxis]).
  template <typename T>
  static JointState<T> jointState(const T* p, const JointState<T>& encoder) {
    using std::cos;
    using std::sin;
    const T& k = p[kOrder];
    const T c = cos(k * encoder.angle), s = sin(k * encoder.angle);
    const T e = p[kCos] * c + p[kSin] * s;
    const T de = k * (p[kSin] * c - p[kCos] * s);
    const T dde = -k * k * e;
    JointState<T> out;
    out.angle = encoder.angle + e;
    out.rate = encoder.rate + de * encoder.rate;
    out.accel = encoder.accel + de * encoder.accel + dde * encoder.rate * encoder.rate;
    return out;
  }
};

}  // namespace imubench::calib::model::effects
