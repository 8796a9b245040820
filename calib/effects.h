// Extra physical effects of the bench forward model: the double-precision front of the effect
// units in calib/model/effects/ (registry: calib/model/effects.h; what a unit is:
// calib/model/effect_unit.h; how to add one: docs/forward-model.md).
//
// Every effect has a stable id (interchange.md "Effect identifiers"), named parameters and
// one term in the forward model (the unit states it; here in short):
//   lever_arm           r_m (m, B): f += w' x r + w x (w x r), w = w_LB_B      (specific force)
//   size_effect         d_y_m, d_z_m (m, B): y/z accelerometer points relative to x's (at
//                       lever_arm.r_m); axis k senses f at its own point        (axis input)
//   gyro_g_sensitivity  G (3x3, rad/s per m/s^2): gyro input += G f              (rate)
//   thermal_bias        k_accel, k_gyro (per axis, per degC), t_ref_c:
//                       bias(T) = bias + k (T - t_ref_c)                         (reading)
//   thermal_scale       k_accel, k_gyro (per axis, 1/degC), t_ref_c:
//                       scale(T) = scale * (1 + k (T - t_ref_c))                 (reading)
//   accel_k2            k2 (per axis, 1/(m/s^2)): u_k += k2_k u_k^2, u = M f      (reading)
//   scale_asymmetry     gyro (per axis): scale is s + a for u > 0 and s - a for u < 0, i.e.
//                       reading_k += a_k |u_k|, u = M w - bias                    (reading)
//   time_delay          tau_s (s): sample stamped t is taken at t - tau_s        (time)
//   accel_delay         tau_s (s): accel sampled at (gyro's time) - tau_s        (time)
//   latitude_error      dlat_rad: true latitude = assumed latitude + dlat_rad     (site)
//   gravity_error       dg_mps2: true gravity = assumed gravity + dg_mps2         (site)
//   base_tilt           x, y (rad): added to the table's base tilt                (table)
//   nonorthogonality    inner_y, middle_x, middle_y (rad): added to the table's   (table)
//   encoder_zero        outer, middle, inner (rad): added to the encoder zeros    (table)
//   mounting            x, y (rad): added to the device mounting                  (table)
//   angle_harmonic      axis (outer|middle|inner), order k, cos_rad, sin_rad: true angle =
//                       encoder a + cos_rad cos(k a) + sin_rad sin(k a)           (angle)
//   bias_instability    accel, gyro (per axis: Allan-deviation minimum), tau_s: a random slow
//                       bias drift the simulator adds (noise process, no term)   (noise)
// "f" in the gyro g-sensitivity term is the specific force the accelerometer triad senses
// (lever arm included).
//
// Parameters can be read and written by name (JSON "extra": {id: {param: value}}) and as a
// flat vector with names ("lever_arm.r_m.x", ...) for fitting: a mismatch analysis makes an
// EffectSet, enables an effect by id, sets its flat vector and evaluates the same forward
// model (forwardReadings below for the reading effects; the simulator, or the helpers at the
// end of this file, for the time, site, table, angle and noise effects).
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "calib/model/bench_physics.h"
#include "calib/model/effects.h"
#include "calib/sensor_model.h"
#include "calib/table_model.h"
#include "nav/rotation.h"

namespace imubench::calib {

// EffectId, kEffectCount, ParamShape, ParamKind and ParamSpec are declared with the units in
// calib/model/effect_unit.h. Every id, in registry (= id) order:
inline constexpr std::array<EffectId, kEffectCount> kAllEffects = [] {
  std::array<EffectId, kEffectCount> ids{};
  for (int i = 0; i < kEffectCount; ++i) {
    ids[static_cast<std::size_t>(i)] = model::kUnitInfos[static_cast<std::size_t>(i)].id;
  }
  return ids;
}();

// Stable interchange id ("lever_arm", ...).
const char* effectName(EffectId id);
std::optional<EffectId> effectFromName(std::string_view name);
// Where the effect's term acts (calib/model/effect_unit.h Stage) and the term in words.
model::Stage effectStage(EffectId id);
const char* effectTermText(EffectId id);

int paramSize(ParamShape shape);
// The parameters of an effect, in flat-vector order.
std::span<const ParamSpec> paramSpecs(EffectId id);
// Flat names "<effect>.<param>[.<component>]": components x|y|z for vectors, xx|xy|..|zz for
// matrices (row, column). Length = flat size of the effect.
std::vector<std::string> flatParamNames(EffectId id);
int flatSize(EffectId id);
// Table axis names of ParamKind::kTableAxis values ("outer", "middle", "inner") and back.
const char* tableAxisName(int axis);
std::optional<int> tableAxisFromName(std::string_view name);

// ---- The effect units' parameters (terms: calib/model/effects/*.h) ------------------------

struct LeverArm {
  Vec3 r_m = Vec3::Zero();
  // Specific force added at the sensing point.
  Vec3 specificForceTerm(const Vec3& w_LB_B, const Vec3& wdot_LB_B) const {
    return model::leverArmTerm(w_LB_B, wdot_LB_B, r_m);
  }
};

struct TimeDelay {
  double tau_s = 0.0;
};

struct GyroGSensitivity {
  Mat3 G = Mat3::Zero();
  Vec3 rateTerm(const Vec3& f_B) const { return G * f_B; }
};

struct ThermalBias {
  Vec3 k_accel = Vec3::Zero();  // m/s^2 per degC
  Vec3 k_gyro = Vec3::Zero();   // rad/s per degC
  double t_ref_c = 20.0;
};

struct ThermalScale {
  Vec3 k_accel = Vec3::Zero();  // 1/degC
  Vec3 k_gyro = Vec3::Zero();   // 1/degC
  double t_ref_c = 20.0;
};

struct ScaleAsymmetry {
  Vec3 gyro = Vec3::Zero();  // half difference of +/- scale, per axis (dimensionless)
};

struct AccelK2 {
  Vec3 k2 = Vec3::Zero();  // 1/(m/s^2)
};

struct LatitudeError {
  double dlat_rad = 0.0;
};

struct GravityError {
  double dg_mps2 = 0.0;
};

struct SizeEffect {
  Vec3 d_y_m = Vec3::Zero();  // y accelerometer's point relative to x's, m (B)
  Vec3 d_z_m = Vec3::Zero();  // z accelerometer's point relative to x's, m (B)
};

struct AccelDelay {
  double tau_s = 0.0;  // accel sampled this much before the gyro, s
};

struct AngleHarmonic {
  double axis = kTableAxisOuter;  // kTableAxisOuter / Middle / Inner
  double order = 1.0;             // k, integer >= 1
  double cos_rad = 0.0;
  double sin_rad = 0.0;
};

struct BiasInstability {
  Vec3 accel = Vec3::Zero();  // Allan-deviation minimum per axis, m/s^2
  Vec3 gyro = Vec3::Zero();   // Allan-deviation minimum per axis, rad/s
  double tau_s = 100.0;       // where the minimum occurs, s (typical: tens to hundreds of s)
};

struct BaseTilt {
  double x = 0.0, y = 0.0;  // rad, in L
};

struct Mounting {
  double x = 0.0, y = 0.0;  // rad
};

// nonorthogonality and encoder_zero use the table's own structs (calib/table_model.h):
// Nonorthogonality {inner_y, middle_x, middle_y}, EncoderZero {outer, middle, inner}.

// The enabled effects (at most one of each id).
struct EffectSet {
  std::optional<LeverArm> lever_arm;
  std::optional<TimeDelay> time_delay;
  std::optional<GyroGSensitivity> gyro_g_sensitivity;
  std::optional<ThermalBias> thermal_bias;
  std::optional<ThermalScale> thermal_scale;
  std::optional<ScaleAsymmetry> scale_asymmetry;
  std::optional<AccelK2> accel_k2;
  std::optional<LatitudeError> latitude_error;
  std::optional<GravityError> gravity_error;
  std::optional<SizeEffect> size_effect;
  std::optional<AccelDelay> accel_delay;
  std::optional<AngleHarmonic> angle_harmonic;
  std::optional<BiasInstability> bias_instability;
  std::optional<BaseTilt> base_tilt;
  std::optional<Nonorthogonality> nonorthogonality;
  std::optional<EncoderZero> encoder_zero;
  std::optional<Mounting> mounting;

  bool has(EffectId id) const;
  // Enables the effect with its default parameters if absent (zeros; t_ref_c = 20,
  // angle_harmonic order 1 on the outer axis, bias_instability tau_s = 100); keeps it if
  // present.
  void enable(EffectId id);
  void disable(EffectId id);
  std::vector<EffectId> enabled() const;  // in kAllEffects order
  bool empty() const { return enabled().empty(); }

  // Flat parameter vector of one effect (zeros if disabled), in flatParamNames order.
  std::vector<double> flat(EffectId id) const;
  // Enables the effect and sets all its parameters; false (why set) on a size mismatch, a
  // non-finite value or a discrete parameter out of its set (ParamKind).
  bool setFlat(EffectId id, std::span<const double> values, std::string* why);
  // One named parameter (see paramSpecs); values has paramSize(shape) numbers.
  std::optional<std::vector<double>> param(EffectId id, std::string_view name) const;
  bool setParam(EffectId id, std::string_view name, std::span<const double> values,
                std::string* why);
};

// The enabled effects' parameter blocks for the templated model (calib/model/effects.h),
// copy-safe: blocks() points into this object.
struct EffectBlockStore {
  std::array<std::array<double, model::kMaxEffectFlatSize>, kEffectCount> values{};
  std::array<bool, kEffectCount> on{};
  model::EffectBlocks<double> blocks() const;
};
EffectBlockStore effectBlocks(const EffectSet& effects);

// ---- The forward model at one instant ---------------------------------------------------

// What the bench physics gives at one instant (at the intersection of the table axes, B).
struct PhysicsPoint {
  Vec3 f_B = Vec3::Zero();        // specific force, m/s^2
  Vec3 w_IB_B = Vec3::Zero();     // inertial angular rate, rad/s
  Vec3 w_LB_B = Vec3::Zero();     // table angular rate, rad/s (lever arm, size effect)
  Vec3 wdot_LB_B = Vec3::Zero();  // its derivative, rad/s^2 (lever arm, size effect)
  double temp_c = 20.0;           // sensor temperature, degC
};

struct Readings {
  Vec3 accel = Vec3::Zero();  // m/s^2
  Vec3 gyro = Vec3::Zero();   // rad/s
};

// Noise-free readings of the sensors with all enabled reading-stage effects (lever arm, size
// effect, g-sensitivity, thermal bias/scale, accel k2, scale asymmetry): the double
// instantiation of model::sensorReadings. The other effects act on the time, site, table,
// angles or noise, i.e. on the PhysicsPoint itself (see the helpers below and simulator.h).
Readings forwardReadings(const SensorModel& sensors, const EffectSet& effects,
                         const PhysicsPoint& p);

// forwardReadings with the parameter blocks of the sensors and effects prepared once, for hot
// loops (the simulator): same function, same results.
class ForwardModel {
 public:
  ForwardModel(const SensorModel& sensors, const EffectSet& effects);
  ForwardModel(const ForwardModel& other);
  ForwardModel& operator=(const ForwardModel& other);
  Readings readings(const PhysicsPoint& p) const;

 private:
  model::TriadCoefficients<double> accel_, gyro_;
  EffectBlockStore effects_;
  // effects_.blocks(), made once (not per call: issue 31); they point into effects_, so a copy
  // makes its own.
  model::EffectBlocks<double> blocks_{};
};

// The reading change one effect makes: forwardReadings(all) - forwardReadings(all but id).
// Zero for the effects that act on the PhysicsPoint (time, site, table, angle, noise).
Readings effectTerm(EffectId id, const SensorModel& sensors, const EffectSet& effects,
                    const PhysicsPoint& p);

// Sets one parameter from text "<id>.<param>=<v>[,<v>...]" (numbers, SI; a matrix row-major;
// a table axis by name: "angle_harmonic.axis=inner"), enabling the effect. False (why set,
// naming the part at fault) on an unknown id or parameter, a wrong count or a bad number.
bool setEffectParamFromText(EffectSet* effects, std::string_view text, std::string* why);

// ---- The effects that act before the instant's physics ----------------------------------

// The table errors with the table effects (base_tilt, nonorthogonality, encoder_zero,
// mounting) added.
TableErrors tableErrorsWithEffects(const TableErrors& errors, const EffectSet& effects);
// The true (physical, before the encoder zeros) table state from the encoder state: the
// angle_harmonic effect. A harmonic on the middle axis of a two-axis table does nothing.
TableState trueTableState(const TableState& encoder, const EffectSet& effects);
// The physics times of the gyros and of the accelerometers for a sample stamped t (table
// clock): time_delay and accel_delay.
double gyroPhysicsTime(double t_stamp, const EffectSet& effects);
double accelPhysicsTime(double t_stamp, const EffectSet& effects);

}  // namespace imubench::calib
