// What every effect unit of the forward model (calib/model/effects/*.h, grouped by stage) is
// made of: its id, its named parameters and where its term acts. The registry of units is
// calib/model/effects.h; the double-precision front (EffectSet, JSON names) is calib/effects.h.
//
// A unit is a struct with
//   kId      the EffectId that links it to its row of the registry's metadata table
//            (kUnitRows in calib/model/effects.h: name, parameters, stage, term in words),
//   a named offset per parameter (e.g. LeverArm::kR) into the unit's parameter block, in
//            the flat-vector order of its row's parameters (name, shape, unit, kind),
//   the term itself, templated on the scalar T (double or ceres::Jet) and reading the
//   parameter block `const T* p`: `apply(p, ReadingState<T>*)` for the reading stages, a
//   named function for the others (sampleTime, trueValue, addTo, jointState, ...).
// Units whose terms have the same form are one template with an alias per effect
// (SiteOffsetUnit, TableErrorUnit, DelayUnit, ThermalUnit); a table-error unit names the
// chain slot of each parameter (kSlots) instead of an offset per parameter.
#pragma once

#include <array>
#include <cstddef>

#include "calib/model/scalar.h"

namespace imubench::calib {

// Stable ids of the effects (effectName gives the interchange string). New ids are appended:
// the values are stable, the order of application is the unit's Stage, not the id.
enum class EffectId {
  kLeverArm,
  kTimeDelay,
  kGyroGSensitivity,
  kThermalBias,
  kThermalScale,
  kScaleAsymmetry,
  kAccelK2,
  kLatitudeError,
  kGravityError,
  kSizeEffect,
  kAccelDelay,
  kAngleHarmonic,
  kBiasInstability,
  kBaseTilt,
  kNonorthogonality,
  kEncoderZero,
  kMounting,
};
inline constexpr int kEffectCount = 17;

// Shape of one named parameter of an effect.
enum class ParamShape { kScalar, kVec3, kMat3 };  // 1, 3 or 9 (row-major) numbers
// What values a (scalar) parameter takes. Discrete parameters select the structure of the
// term and are not fitted: kInteger is a whole number >= 1 (JSON integer); kTableAxis is
// 0 outer, 1 middle, 2 inner (JSON "outer" | "middle" | "inner").
enum class ParamKind { kReal, kInteger, kTableAxis };
struct ParamSpec {
  const char* name = nullptr;  // JSON key, e.g. "r_m"
  ParamShape shape = ParamShape::kScalar;
  const char* unit = nullptr;  // SI unit, for reports
  ParamKind kind = ParamKind::kReal;
};

inline constexpr int kTableAxisOuter = 0;
inline constexpr int kTableAxisMiddle = 1;
inline constexpr int kTableAxisInner = 2;

namespace model {

// Where an effect's term acts, in the order the forward model applies them.
enum class Stage {
  kSite,           // the true site (latitude, gravity) before the physics
  kTable,          // the table chain's geometric errors before the kinematics
  kAngle,          // the table's physical joint angles (from the encoder angles)
  kTime,           // the instant at which the physics is sampled
  kBodyInput,      // specific force / rate in B at the instant (ReadingState f_B, w_IB_B)
  kCoefficients,   // the triads' bias and scale at the instant (temperature)
  kAxisInput,      // each axis' linear input u = M f (before the nonlinearity and bias)
  kAxisNonlinear,  // the axis input's nonlinearity (on the whole u, before the bias)
  kReading,        // the reading after the sensor equation
  kNoise,          // a random process the simulator adds (no deterministic term)
};

// Everything the reading-stage terms see and change at one instant (frame B, SI).
template <typename T>
struct ReadingState {
  // Bench physics at the axes' intersection (kBodyInput terms change f_B and w_IB_B).
  Vec3T<T> f_B = Vec3T<T>::Zero();
  Vec3T<T> w_IB_B = Vec3T<T>::Zero();
  Vec3T<T> w_LB_B = Vec3T<T>::Zero();
  Vec3T<T> wdot_LB_B = Vec3T<T>::Zero();
  T temp_c = T(20.0);
  // The triads' coefficients (kCoefficients terms change bias and scale).
  Vec3T<T> scale_a = Vec3T<T>::Ones(), bias_a = Vec3T<T>::Zero();
  Vec3T<T> scale_g = Vec3T<T>::Ones(), bias_g = Vec3T<T>::Zero();
  Mat3T<T> M_a = Mat3T<T>::Identity(), M_g = Mat3T<T>::Identity();
  // Axis inputs: M f and M w at kAxisInput / kAxisNonlinear, then minus the bias at kReading.
  Vec3T<T> u_a = Vec3T<T>::Zero(), u_g = Vec3T<T>::Zero();
  // Readings diag(scale) u (kReading terms add to them).
  Vec3T<T> accel = Vec3T<T>::Zero(), gyro = Vec3T<T>::Zero();
};

// Three consecutive parameters as a vector.
template <typename T>
Vec3T<T> vec3At(const T* p) {
  return Vec3T<T>(p[0], p[1], p[2]);
}

}  // namespace model
}  // namespace imubench::calib
