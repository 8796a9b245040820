// Extra physical effects of the bench forward model, one small unit each.
//
// Every effect has a stable id (interchange.md "Effect identifiers"), named parameters and
// one term in the forward model:
//   lever_arm           r_m (m, B): f += w' x r + w x (w x r), w = w_LB_B      (specific force)
//   time_delay          tau_s (s): sample stamped t is taken at t - tau_s        (timing;
//   simulator) gyro_g_sensitivity  G (3x3, rad/s per m/s^2): gyro input += G f              (rate)
//   thermal_bias        k_accel, k_gyro (per axis, per degC), t_ref_c:
//                       bias(T) = bias + k (T - t_ref_c)                         (reading)
//   thermal_scale       k_accel, k_gyro (per axis, 1/degC), t_ref_c:
//                       scale(T) = scale * (1 + k (T - t_ref_c))                 (reading)
//   scale_asymmetry     gyro (per axis): scale is s + a for u > 0 and s - a for u < 0, i.e.
//                       reading_k += a_k |u_k|, u = M w - bias                    (reading)
//   accel_k2            k2 (per axis, 1/(m/s^2)): u_k += k2_k u_k^2, u = M f      (reading)
//   latitude_error      dlat_rad: true latitude = assumed latitude + dlat_rad     (site)
//   gravity_error       dg_mps2: true gravity = assumed gravity + dg_mps2         (site)
// "f" in the gyro g-sensitivity term is the specific force the accelerometer triad senses
// (lever arm included).
//
// Parameters can be read and written by name (JSON "extra": {id: {param: value}}) and as a
// flat vector with names ("lever_arm.r_m.x", ...) for fitting: a mismatch analysis makes an
// EffectSet, enables an effect by id, sets its flat vector and evaluates the same forward
// model (forwardReadings below, or the simulator for timing and site effects).
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "calib/model/bench_physics.h"
#include "calib/sensor_model.h"
#include "nav/rotation.h"

namespace imubench::calib {

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
};
inline constexpr int kEffectCount = 9;
inline constexpr std::array<EffectId, kEffectCount> kAllEffects = {
    EffectId::kLeverArm,    EffectId::kTimeDelay,     EffectId::kGyroGSensitivity,
    EffectId::kThermalBias, EffectId::kThermalScale,  EffectId::kScaleAsymmetry,
    EffectId::kAccelK2,     EffectId::kLatitudeError, EffectId::kGravityError,
};

// Stable interchange id ("lever_arm", ...).
const char* effectName(EffectId id);
std::optional<EffectId> effectFromName(std::string_view name);

// Shape of one named parameter of an effect.
enum class ParamShape { kScalar, kVec3, kMat3 };  // 1, 3 or 9 (row-major) numbers
struct ParamSpec {
  const char* name;  // JSON key, e.g. "r_m"
  ParamShape shape;
  const char* unit;  // SI unit, for reports
};
int paramSize(ParamShape shape);
// The parameters of an effect, in flat-vector order.
std::span<const ParamSpec> paramSpecs(EffectId id);
// Flat names "<effect>.<param>[.<component>]": components x|y|z for vectors, xx|xy|..|zz for
// matrices (row, column). Length = flat size of the effect.
std::vector<std::string> flatParamNames(EffectId id);
int flatSize(EffectId id);

// ---- The effect units -------------------------------------------------------------------

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

  bool has(EffectId id) const;
  // Enables the effect with zero parameters (t_ref_c = 20) if absent; keeps it if present.
  void enable(EffectId id);
  void disable(EffectId id);
  std::vector<EffectId> enabled() const;  // in kAllEffects order
  bool empty() const { return enabled().empty(); }

  // Flat parameter vector of one effect (zeros if disabled), in flatParamNames order.
  std::vector<double> flat(EffectId id) const;
  // Enables the effect and sets all its parameters; false (why set) on a size mismatch or a
  // non-finite value.
  bool setFlat(EffectId id, std::span<const double> values, std::string* why);
  // One named parameter (see paramSpecs); values has paramSize(shape) numbers.
  std::optional<std::vector<double>> param(EffectId id, std::string_view name) const;
  bool setParam(EffectId id, std::string_view name, std::span<const double> values,
                std::string* why);
};

// ---- The forward model at one instant ---------------------------------------------------

// What the bench physics gives at one instant (at the intersection of the table axes, B).
struct PhysicsPoint {
  Vec3 f_B = Vec3::Zero();        // specific force, m/s^2
  Vec3 w_IB_B = Vec3::Zero();     // inertial angular rate, rad/s
  Vec3 w_LB_B = Vec3::Zero();     // table angular rate, rad/s (lever arm)
  Vec3 wdot_LB_B = Vec3::Zero();  // its derivative, rad/s^2 (lever arm)
  double temp_c = 20.0;           // sensor temperature, degC
};

struct Readings {
  Vec3 accel = Vec3::Zero();  // m/s^2
  Vec3 gyro = Vec3::Zero();   // rad/s
};

// Noise-free readings of the sensors with all enabled instantaneous effects (lever arm,
// g-sensitivity, thermal bias/scale, scale asymmetry, accel k2). time_delay, latitude_error and
// gravity_error act on time and site, i.e. on the PhysicsPoint itself (see simulator.h).
Readings forwardReadings(const SensorModel& sensors, const EffectSet& effects,
                         const PhysicsPoint& p);

// The reading change one effect makes: forwardReadings(all) - forwardReadings(all but id).
// Zero for the time/site effects (their term is in the PhysicsPoint).
Readings effectTerm(EffectId id, const SensorModel& sensors, const EffectSet& effects,
                    const PhysicsPoint& p);

}  // namespace imubench::calib
