// The registry of the forward model's effect units (calib/model/effect_unit.h says what a unit
// is) and the templated forward pass that applies them with the sensor equation at one
// instant. The units are grouped by stage, one header per group in calib/model/effects/:
//   site.h     kSite          latitude_error, gravity_error (SiteOffsetUnit: assumed + p[0])
//   table.h    kTable         base_tilt, nonorthogonality, encoder_zero, mounting
//                             (TableErrorUnit: each parameter added to one chain block slot)
//              kAngle         angle_harmonic
//   time.h     kTime          time_delay, accel_delay (DelayUnit: sample time t - p[0])
//   reading.h  kBodyInput     lever_arm, gyro_g_sensitivity
//              kAxisInput     size_effect
//              kAxisNonlinear accel_k2
//              kReading       scale_asymmetry
//   thermal.h  kCoefficients  thermal_bias, thermal_scale (ThermalUnit: one parameter layout)
//   noise.h    kNoise         bias_instability
//
// Order of application: by the units' Stage (effect_unit.h), and within a stage by their
// order here. Reading stages at one instant (sensorReadings below):
//   kBodyInput      f_B, w_IB_B at the axes' intersection -> lever_arm, gyro_g_sensitivity
//   kCoefficients   bias, scale of both triads            -> thermal_bias, thermal_scale
//   u_a = M_a f_B, u_g = M_g w_IB_B
//   kAxisInput      linear axis input                      -> size_effect
//   kAxisNonlinear  nonlinear axis input                   -> accel_k2
//   u -= bias;  reading = diag(scale) u                       (calib/model/sensor_equation.h)
//   kReading        the readings                           -> scale_asymmetry
// The other stages act before the instant's physics (the simulator, calib/simulator.h, and
// any caller that builds the physics): kSite (latitude_error, gravity_error), kTable
// (base_tilt, nonorthogonality, encoder_zero, mounting: addTableEffects), kAngle
// (angle_harmonic: trueJointStates), kTime (time_delay, accel_delay), kNoise (bias_instability).
#pragma once

#include <array>
#include <cmath>
#include <span>
#include <type_traits>

#include "calib/model/effect_unit.h"
#include "calib/model/effects/noise.h"
#include "calib/model/effects/reading.h"
#include "calib/model/effects/site.h"
#include "calib/model/effects/table.h"
#include "calib/model/effects/thermal.h"
#include "calib/model/effects/time.h"
#include "calib/model/sensor_equation.h"
#include "calib/model/table_chain.h"

namespace imubench::calib::model {

template <class... U>
struct UnitList {};

// THE registry: every effect unit, in EffectId order (checked below).
using EffectUnits =
    UnitList<effects::LeverArm, effects::TimeDelay, effects::GyroGSensitivity, effects::ThermalBias,
             effects::ThermalScale, effects::ScaleAsymmetry, effects::AccelK2,
             effects::LatitudeError, effects::GravityError, effects::SizeEffect,
             effects::AccelDelay, effects::AngleHarmonic, effects::BiasInstability,
             effects::BaseTilt, effects::Nonorthogonality, effects::EncoderZero, effects::Mounting>;

// What the double front (calib/effects.*) reads of a unit.
struct UnitInfo {
  EffectId id;
  const char* name;                   // interchange.md "Effect identifiers"
  std::span<const ParamSpec> params;  // in flat-vector order: the unit's offsets index them
  Stage stage;                        // where the term acts
  const char* term;                   // the term in words, for reports
};

// One row of the table below: a unit's parameters inline (up to kMaxUnitParams; the unused
// entries have no name).
inline constexpr int kMaxUnitParams = 4;
struct UnitRow {
  EffectId id{};
  const char* name = nullptr;
  Stage stage{};
  const char* term = nullptr;
  std::array<ParamSpec, kMaxUnitParams> params{};
};

// THE metadata of every unit, in EffectId order (checked below); the unit's header holds its
// parameter offsets and its term.
inline constexpr UnitRow kUnitRows[] = {
    {EffectId::kLeverArm,
     "lever_arm",
     Stage::kBodyInput,
     "f += w' x r + w x (w x r), w = w_LB_B",
     {{{"r_m", ParamShape::kVec3, "m"}}}},
    {EffectId::kTimeDelay,
     "time_delay",
     Stage::kTime,
     "physics sampled at t - tau_s",
     {{{"tau_s", ParamShape::kScalar, "s"}}}},
    {EffectId::kGyroGSensitivity,
     "gyro_g_sensitivity",
     Stage::kBodyInput,
     "w += G f",
     {{{"G", ParamShape::kMat3, "rad/s/(m/s^2)"}}}},
    {EffectId::kThermalBias,
     "thermal_bias",
     Stage::kCoefficients,
     "bias(T) = bias + k (T - t_ref_c)",
     {{{"k_accel", ParamShape::kVec3, "m/s^2/degC"},
       {"k_gyro", ParamShape::kVec3, "rad/s/degC"},
       {"t_ref_c", ParamShape::kScalar, "degC"}}}},
    {EffectId::kThermalScale,
     "thermal_scale",
     Stage::kCoefficients,
     "scale(T) = scale (1 + k (T - t_ref_c))",
     {{{"k_accel", ParamShape::kVec3, "1/degC"},
       {"k_gyro", ParamShape::kVec3, "1/degC"},
       {"t_ref_c", ParamShape::kScalar, "degC"}}}},
    {EffectId::kScaleAsymmetry,
     "scale_asymmetry",
     Stage::kReading,
     "gyro_k += a_k |u_k|, u = M w - bias",
     {{{"gyro", ParamShape::kVec3, "1"}}}},
    {EffectId::kAccelK2,
     "accel_k2",
     Stage::kAxisNonlinear,
     "u_k += k2_k u_k^2, u = M f",
     {{{"k2", ParamShape::kVec3, "1/(m/s^2)"}}}},
    {EffectId::kLatitudeError,
     "latitude_error",
     Stage::kSite,
     "latitude = assumed + dlat_rad",
     {{{"dlat_rad", ParamShape::kScalar, "rad"}}}},
    {EffectId::kGravityError,
     "gravity_error",
     Stage::kSite,
     "gravity = assumed + dg_mps2",
     {{{"dg_mps2", ParamShape::kScalar, "m/s^2"}}}},
    {EffectId::kSizeEffect,
     "size_effect",
     Stage::kAxisInput,
     "u_k += M_k . (w' x d_k + w x (w x d_k)), k = y, z",
     {{{"d_y_m", ParamShape::kVec3, "m"}, {"d_z_m", ParamShape::kVec3, "m"}}}},
    {EffectId::kAccelDelay,
     "accel_delay",
     Stage::kTime,
     "accelerometer physics sampled at t_gyro - tau_s",
     {{{"tau_s", ParamShape::kScalar, "s"}}}},
    {EffectId::kAngleHarmonic,
     "angle_harmonic",
     Stage::kAngle,
     "angle = encoder + cos_rad cos(k a) + sin_rad sin(k a)",
     {{{"axis", ParamShape::kScalar, "", ParamKind::kTableAxis},
       {"order", ParamShape::kScalar, "", ParamKind::kInteger},
       {"cos_rad", ParamShape::kScalar, "rad"},
       {"sin_rad", ParamShape::kScalar, "rad"}}}},
    {EffectId::kBiasInstability,
     "bias_instability",
     Stage::kNoise,
     "Gauss-Markov bias drift, Allan maximum B at tau_s",
     {{{"accel", ParamShape::kVec3, "m/s^2"},
       {"gyro", ParamShape::kVec3, "rad/s"},
       {"tau_s", ParamShape::kScalar, "s"}}}},
    {EffectId::kBaseTilt,
     "base_tilt",
     Stage::kTable,
     "table base_tilt += (x, y)",
     {{{"x", ParamShape::kScalar, "rad"}, {"y", ParamShape::kScalar, "rad"}}}},
    {EffectId::kNonorthogonality,
     "nonorthogonality",
     Stage::kTable,
     "table nonorthogonality += (inner_y, middle_x, middle_y)",
     {{{"inner_y", ParamShape::kScalar, "rad"},
       {"middle_x", ParamShape::kScalar, "rad"},
       {"middle_y", ParamShape::kScalar, "rad"}}}},
    {EffectId::kEncoderZero,
     "encoder_zero",
     Stage::kTable,
     "table encoder_zero += (outer, middle, inner)",
     {{{"outer", ParamShape::kScalar, "rad"},
       {"middle", ParamShape::kScalar, "rad"},
       {"inner", ParamShape::kScalar, "rad"}}}},
    {EffectId::kMounting,
     "mounting",
     Stage::kTable,
     "table mounting += (x, y)",
     {{{"x", ParamShape::kScalar, "rad"}, {"y", ParamShape::kScalar, "rad"}}}},
};

constexpr std::array<UnitInfo, kEffectCount> unitInfos() {
  std::array<UnitInfo, kEffectCount> out{};
  for (std::size_t i = 0; i < out.size(); ++i) {
    const UnitRow& row = kUnitRows[i];
    std::size_t n = 0;
    while (n < row.params.size() && row.params[n].name != nullptr) ++n;
    out[i] = {row.id, row.name, std::span<const ParamSpec>(row.params.data(), n), row.stage,
              row.term};
  }
  return out;
}
inline constexpr std::array<UnitInfo, kEffectCount> kUnitInfos = unitInfos();
static_assert(std::size(kUnitRows) == kEffectCount, "every EffectId has one row");

// The stage of a unit (by its kId) from the table.
template <class Unit>
inline constexpr Stage kStageOf = kUnitInfos[static_cast<std::size_t>(Unit::kId)].stage;

constexpr bool rowsInIdOrder() {
  for (int i = 0; i < kEffectCount; ++i) {
    if (static_cast<int>(kUnitInfos[static_cast<std::size_t>(i)].id) != i) return false;
  }
  return true;
}
static_assert(rowsInIdOrder(), "kUnitRows lists the units in EffectId order");
template <class... U>
constexpr bool unitsInIdOrder(UnitList<U...>) {
  int i = 0;
  return sizeof...(U) == kEffectCount && ((static_cast<int>(U::kId) == i++) && ...);
}
static_assert(unitsInIdOrder(EffectUnits{}), "EffectUnits lists the units in EffectId order");

// Every table-error unit adds each parameter of its row to one slot.
template <class... U>
constexpr bool tableSlotsMatchRows(UnitList<U...>) {
  const auto one = [](auto unit) {
    using Unit = decltype(unit);
    if constexpr (kStageOf<Unit> == Stage::kTable) {
      return Unit::kSlots.size() == kUnitInfos[static_cast<std::size_t>(Unit::kId)].params.size();
    } else {
      return true;
    }
  };
  return (one(U{}) && ...);
}
static_assert(tableSlotsMatchRows(EffectUnits{}), "a table unit names one slot per parameter");

// Largest flat parameter count of any unit (callers size fixed buffers with it).
constexpr int maxUnitFlatSize() {
  int best = 0;
  for (const UnitInfo& u : kUnitInfos) {
    int n = 0;
    for (const ParamSpec& p : u.params) {
      n += p.shape == ParamShape::kScalar ? 1 : p.shape == ParamShape::kVec3 ? 3 : 9;
    }
    best = n > best ? n : best;
  }
  return best;
}
inline constexpr int kMaxEffectFlatSize = maxUnitFlatSize();

// The parameter block of every effect, by EffectId value; nullptr = effect off.
template <typename T>
using EffectBlocks = std::array<const T*, kEffectCount>;

template <typename T>
const T* blockOf(const EffectBlocks<T>& fx, EffectId id) {
  return fx[static_cast<std::size_t>(id)];
}

// The value part of a scalar (double itself, a Jet's .a): for discrete parameters only.
template <typename T>
double valueOf(const T& x) {
  if constexpr (std::is_same_v<T, double>) {
    return x;
  } else {
    return x.a;
  }
}

// Calls f(Unit{}, p) for every unit of stage S that is enabled (its block p not nullptr), in
// registry order: the one loop of the passes below.
template <Stage S, typename T, class F, class... U>
void forEachEnabledUnit(const EffectBlocks<T>& fx, F&& f, UnitList<U...>) {
  const auto one = [&](auto unit) {
    using Unit = decltype(unit);
    if constexpr (kStageOf<Unit> == S) {
      if (const T* p = blockOf(fx, Unit::kId)) f(unit, p);
    }
  };
  (one(U{}), ...);
}

// Applies the reading-stage terms of stage S of every enabled unit, in registry order.
template <Stage S, typename T>
void applyStage(const EffectBlocks<T>& fx, ReadingState<T>* s) {
  forEachEnabledUnit<S>(
      fx, [s](auto unit, const T* p) { decltype(unit)::apply(p, s); }, EffectUnits{});
}

// The sensor-equation coefficients of one triad (from its kTriadSize block), prepared once.
template <typename T>
struct TriadCoefficients {
  Vec3T<T> scale = Vec3T<T>::Ones();
  Vec3T<T> bias = Vec3T<T>::Zero();
  Mat3T<T> M = Mat3T<T>::Identity();
};
template <typename T>
TriadCoefficients<T> triadCoefficients(const T* triad) {
  return {scaleOf(triad), biasOf(triad), misalignmentMatrix(triad + kMis)};
}

// Noise-free readings of both triads with the reading-stage effects, for the physics in s
// (f_B, w_IB_B, w_LB_B, wdot_LB_B, temp_c). Fills the rest of s; the readings are s->accel,
// s->gyro.
template <typename T>
void sensorReadings(const TriadCoefficients<T>& accel, const TriadCoefficients<T>& gyro,
                    const EffectBlocks<T>& fx, ReadingState<T>* s) {
  s->scale_a = accel.scale;
  s->bias_a = accel.bias;
  s->M_a = accel.M;
  s->scale_g = gyro.scale;
  s->bias_g = gyro.bias;
  s->M_g = gyro.M;
  applyStage<Stage::kBodyInput>(fx, s);
  applyStage<Stage::kCoefficients>(fx, s);
  s->u_a = s->M_a * s->f_B;
  s->u_g = s->M_g * s->w_IB_B;
  applyStage<Stage::kAxisInput>(fx, s);
  applyStage<Stage::kAxisNonlinear>(fx, s);
  s->u_a -= s->bias_a;
  s->u_g -= s->bias_g;
  s->accel = s->scale_a.cwiseProduct(s->u_a);
  s->gyro = s->scale_g.cwiseProduct(s->u_g);
  applyStage<Stage::kReading>(fx, s);
}

// The same from the triads' parameter blocks (kTriadSize each, sensor_equation.h).
template <typename T>
void sensorReadings(const T* accel_triad, const T* gyro_triad, const EffectBlocks<T>& fx,
                    ReadingState<T>* s) {
  sensorReadings(triadCoefficients(accel_triad), triadCoefficients(gyro_triad), fx, s);
}

// Adds the kTable units' errors to the chain's axes block (kTableAxesSize) and device block
// (kTableDeviceSize).
template <typename T>
void addTableEffects(const EffectBlocks<T>& fx, T* axes, T* device) {
  forEachEnabledUnit<Stage::kTable>(
      fx, [axes, device](auto unit, const T* p) { decltype(unit)::addTo(p, axes, device); },
      EffectUnits{});
}

// The true joint states from the encoder states (index kTableAxisOuter / Middle / Inner) by
// the kAngle units (each acts on the axis its p[Unit::kAxis] names).
template <typename T>
void trueJointStates(const EffectBlocks<T>& fx, std::array<JointState<T>, 3>* joints) {
  const auto one = [joints](auto unit, const T* p) {
    using Unit = decltype(unit);
    const long axis = std::lround(valueOf(p[Unit::kAxis]));
    if (axis >= kTableAxisOuter && axis <= kTableAxisInner) {
      JointState<T>& j = (*joints)[static_cast<std::size_t>(axis)];
      j = Unit::jointState(p, j);
    }
  };
  forEachEnabledUnit<Stage::kAngle>(fx, one, EffectUnits{});
}

}  // namespace imubench::calib::model
