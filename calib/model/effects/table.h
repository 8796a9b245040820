// The table units: the chain's geometric errors (Stage::kTable) and its joint angles
// (Stage::kAngle), calib/model/table_chain.h.
//
// Table-error units: each parameter (rad) is added to one slot of the chain's axes block
// (kTableAxesSize) or device block (kTableDeviceSize) before the kinematics; parameter i of
// the unit's row (kUnitRows, calib/model/effects.h) goes to slot kSlots[i]:
//   base_tilt:        x, y: the table base's levelling error theta = (x, y, 0) in L
//                     -> axes kTiltX, kTiltY
//   nonorthogonality: inner_y, middle_x, middle_y: the table axes' perpendicularity errors
//                     (two-axis nu = (0, inner_y, 0); three-axis nu1 = (middle_x, middle_y, 0),
//                     nu2 = (0, inner_y, 0); the middle entries do not act on a two-axis
//                     table) -> axes kNonorthInnerY, kNonorthMiddleX, kNonorthMiddleY
//   encoder_zero:     outer, middle, inner: encoder zero errors (physical angle = encoder
//                     reading + zero; middle only on a three-axis table)
//                     -> device kZeroOuter, kZeroMiddle, kZeroInner
//   mounting:         x, y: the device's installation error on the platform mu = (x, y, 0)
//                     -> device kMountX, kMountY
//
// angle_harmonic: axis (outer | middle | inner), order k (integer >= 1), cos_rad, sin_rad
// (rad): the true angle of that table axis is the encoder angle a + c cos(k a) + s sin(k a)
// (encoder and bearing errors periodic in the angle). Rate and acceleration follow by the
// chain rule:
//   e(a) = c cos(ka) + s sin(ka),  e' = k (s cos(ka) - c sin(ka)),  e'' = -k^2 e(a)
//   angle += e,  rate += e' a_dot,  accel += e' a_ddot + e'' a_dot^2.
// The physical joint angle then adds the encoder zero in the chain.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

#include "calib/model/effect_unit.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model::effects {

// Which parameter block of the chain a table-error unit adds to.
enum class TableBlock { kAxes, kDevice };

template <EffectId Id, TableBlock Block, int... Slots>
struct TableErrorUnit {
  static constexpr EffectId kId = Id;
  static constexpr std::array<int, sizeof...(Slots)> kSlots{Slots...};

  // Adds the errors to the chain's axes and device blocks.
  template <typename T>
  static void addTo(const T* p, T* axes, T* device) {
    T* block = Block == TableBlock::kAxes ? axes : device;
    for (std::size_t i = 0; i < kSlots.size(); ++i) block[kSlots[i]] += p[i];
  }
};

using BaseTilt = TableErrorUnit<EffectId::kBaseTilt, TableBlock::kAxes, kTiltX, kTiltY>;
using Nonorthogonality = TableErrorUnit<EffectId::kNonorthogonality, TableBlock::kAxes,
                                        kNonorthInnerY, kNonorthMiddleX, kNonorthMiddleY>;
using EncoderZero = TableErrorUnit<EffectId::kEncoderZero, TableBlock::kDevice, kZeroOuter,
                                   kZeroMiddle, kZeroInner>;
using Mounting = TableErrorUnit<EffectId::kMounting, TableBlock::kDevice, kMountX, kMountY>;

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
