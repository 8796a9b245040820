#include "calib/effects.h"

#include <cmath>

namespace imubench::calib {
namespace {

constexpr ParamSpec kLeverArmSpecs[] = {{"r_m", ParamShape::kVec3, "m"}};
constexpr ParamSpec kTimeDelaySpecs[] = {{"tau_s", ParamShape::kScalar, "s"}};
constexpr ParamSpec kGyroGSpecs[] = {{"G", ParamShape::kMat3, "rad/s/(m/s^2)"}};
constexpr ParamSpec kThermalBiasSpecs[] = {{"k_accel", ParamShape::kVec3, "m/s^2/degC"},
                                           {"k_gyro", ParamShape::kVec3, "rad/s/degC"},
                                           {"t_ref_c", ParamShape::kScalar, "degC"}};
constexpr ParamSpec kThermalScaleSpecs[] = {{"k_accel", ParamShape::kVec3, "1/degC"},
                                            {"k_gyro", ParamShape::kVec3, "1/degC"},
                                            {"t_ref_c", ParamShape::kScalar, "degC"}};
constexpr ParamSpec kScaleAsymmetrySpecs[] = {{"gyro", ParamShape::kVec3, "1"}};
constexpr ParamSpec kAccelK2Specs[] = {{"k2", ParamShape::kVec3, "1/(m/s^2)"}};
constexpr ParamSpec kLatitudeErrorSpecs[] = {{"dlat_rad", ParamShape::kScalar, "rad"}};
constexpr ParamSpec kGravityErrorSpecs[] = {{"dg_mps2", ParamShape::kScalar, "m/s^2"}};

// Storage of parameter `index` of effect `id` inside an enabled EffectSet (nullptr if the
// effect is disabled). Eigen fixed-size storage is contiguous (column-major for G, so G is
// handled by the caller as row-major through its own mapping).
template <class Set>
auto* paramData(Set& s, EffectId id, int index) {
  using D = std::conditional_t<std::is_const_v<Set>, const double, double>;
  D* p = nullptr;
  switch (id) {
    case EffectId::kLeverArm:
      if (s.lever_arm) p = s.lever_arm->r_m.data();
      break;
    case EffectId::kTimeDelay:
      if (s.time_delay) p = &s.time_delay->tau_s;
      break;
    case EffectId::kGyroGSensitivity:
      if (s.gyro_g_sensitivity) p = s.gyro_g_sensitivity->G.data();
      break;
    case EffectId::kThermalBias:
      if (s.thermal_bias) {
        p = index == 0   ? s.thermal_bias->k_accel.data()
            : index == 1 ? s.thermal_bias->k_gyro.data()
                         : &s.thermal_bias->t_ref_c;
      }
      break;
    case EffectId::kThermalScale:
      if (s.thermal_scale) {
        p = index == 0   ? s.thermal_scale->k_accel.data()
            : index == 1 ? s.thermal_scale->k_gyro.data()
                         : &s.thermal_scale->t_ref_c;
      }
      break;
    case EffectId::kScaleAsymmetry:
      if (s.scale_asymmetry) p = s.scale_asymmetry->gyro.data();
      break;
    case EffectId::kAccelK2:
      if (s.accel_k2) p = s.accel_k2->k2.data();
      break;
    case EffectId::kLatitudeError:
      if (s.latitude_error) p = &s.latitude_error->dlat_rad;
      break;
    case EffectId::kGravityError:
      if (s.gravity_error) p = &s.gravity_error->dg_mps2;
      break;
  }
  return p;
}

// Element `e` of a parameter in flat (row-major for matrices) order -> storage offset.
int storageOffset(ParamShape shape, int e) {
  if (shape != ParamShape::kMat3) return e;
  const int row = e / 3, col = e % 3;
  return col * 3 + row;  // Eigen column-major
}

const char* const kVecComponents[] = {"x", "y", "z"};
const char* const kMatComponents[] = {"xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"};

}  // namespace

const char* effectName(EffectId id) {
  switch (id) {
    case EffectId::kLeverArm:
      return "lever_arm";
    case EffectId::kTimeDelay:
      return "time_delay";
    case EffectId::kGyroGSensitivity:
      return "gyro_g_sensitivity";
    case EffectId::kThermalBias:
      return "thermal_bias";
    case EffectId::kThermalScale:
      return "thermal_scale";
    case EffectId::kScaleAsymmetry:
      return "scale_asymmetry";
    case EffectId::kAccelK2:
      return "accel_k2";
    case EffectId::kLatitudeError:
      return "latitude_error";
    case EffectId::kGravityError:
      return "gravity_error";
  }
  return "?";
}

std::optional<EffectId> effectFromName(std::string_view name) {
  for (EffectId id : kAllEffects) {
    if (name == effectName(id)) return id;
  }
  return std::nullopt;
}

int paramSize(ParamShape shape) {
  switch (shape) {
    case ParamShape::kScalar:
      return 1;
    case ParamShape::kVec3:
      return 3;
    case ParamShape::kMat3:
      return 9;
  }
  return 1;
}

std::span<const ParamSpec> paramSpecs(EffectId id) {
  switch (id) {
    case EffectId::kLeverArm:
      return kLeverArmSpecs;
    case EffectId::kTimeDelay:
      return kTimeDelaySpecs;
    case EffectId::kGyroGSensitivity:
      return kGyroGSpecs;
    case EffectId::kThermalBias:
      return kThermalBiasSpecs;
    case EffectId::kThermalScale:
      return kThermalScaleSpecs;
    case EffectId::kScaleAsymmetry:
      return kScaleAsymmetrySpecs;
    case EffectId::kAccelK2:
      return kAccelK2Specs;
    case EffectId::kLatitudeError:
      return kLatitudeErrorSpecs;
    case EffectId::kGravityError:
      return kGravityErrorSpecs;
  }
  return {};
}

int flatSize(EffectId id) {
  int n = 0;
  for (const ParamSpec& p : paramSpecs(id)) n += paramSize(p.shape);
  return n;
}

std::vector<std::string> flatParamNames(EffectId id) {
  std::vector<std::string> names;
  const std::string prefix = std::string(effectName(id)) + ".";
  for (const ParamSpec& p : paramSpecs(id)) {
    switch (p.shape) {
      case ParamShape::kScalar:
        names.push_back(prefix + p.name);
        break;
      case ParamShape::kVec3:
        for (const char* c : kVecComponents) names.push_back(prefix + p.name + "." + c);
        break;
      case ParamShape::kMat3:
        for (const char* c : kMatComponents) names.push_back(prefix + p.name + "." + c);
        break;
    }
  }
  return names;
}

bool EffectSet::has(EffectId id) const {
  return paramData(*this, id, 0) != nullptr;
}

void EffectSet::enable(EffectId id) {
  if (has(id)) return;
  switch (id) {
    case EffectId::kLeverArm:
      lever_arm.emplace();
      break;
    case EffectId::kTimeDelay:
      time_delay.emplace();
      break;
    case EffectId::kGyroGSensitivity:
      gyro_g_sensitivity.emplace();
      break;
    case EffectId::kThermalBias:
      thermal_bias.emplace();
      break;
    case EffectId::kThermalScale:
      thermal_scale.emplace();
      break;
    case EffectId::kScaleAsymmetry:
      scale_asymmetry.emplace();
      break;
    case EffectId::kAccelK2:
      accel_k2.emplace();
      break;
    case EffectId::kLatitudeError:
      latitude_error.emplace();
      break;
    case EffectId::kGravityError:
      gravity_error.emplace();
      break;
  }
}

void EffectSet::disable(EffectId id) {
  switch (id) {
    case EffectId::kLeverArm:
      lever_arm.reset();
      break;
    case EffectId::kTimeDelay:
      time_delay.reset();
      break;
    case EffectId::kGyroGSensitivity:
      gyro_g_sensitivity.reset();
      break;
    case EffectId::kThermalBias:
      thermal_bias.reset();
      break;
    case EffectId::kThermalScale:
      thermal_scale.reset();
      break;
    case EffectId::kScaleAsymmetry:
      scale_asymmetry.reset();
      break;
    case EffectId::kAccelK2:
      accel_k2.reset();
      break;
    case EffectId::kLatitudeError:
      latitude_error.reset();
      break;
    case EffectId::kGravityError:
      gravity_error.reset();
      break;
  }
}

std::vector<EffectId> EffectSet::enabled() const {
  std::vector<EffectId> out;
  for (EffectId id : kAllEffects) {
    if (has(id)) out.push_back(id);
  }
  return out;
}

std::vector<double> EffectSet::flat(EffectId id) const {
  std::vector<double> out;
  const auto specs = paramSpecs(id);
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    const double* p = paramData(*this, id, i);
    const int n = paramSize(specs[i].shape);
    for (int e = 0; e < n; ++e) {
      out.push_back(p ? p[storageOffset(specs[i].shape, e)] : 0.0);
    }
  }
  return out;
}

bool EffectSet::setFlat(EffectId id, std::span<const double> values, std::string* why) {
  if (static_cast<int>(values.size()) != flatSize(id)) {
    if (why) {
      *why = std::string(effectName(id)) + ": expected " + std::to_string(flatSize(id)) +
             " parameters, got " + std::to_string(values.size());
    }
    return false;
  }
  for (double v : values) {
    if (!std::isfinite(v)) {
      if (why) *why = std::string(effectName(id)) + ": non-finite parameter";
      return false;
    }
  }
  enable(id);
  const auto specs = paramSpecs(id);
  std::size_t k = 0;
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    double* p = paramData(*this, id, i);
    const int n = paramSize(specs[i].shape);
    for (int e = 0; e < n; ++e) p[storageOffset(specs[i].shape, e)] = values[k++];
  }
  return true;
}

std::optional<std::vector<double>> EffectSet::param(EffectId id, std::string_view name) const {
  const auto specs = paramSpecs(id);
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    if (name != specs[i].name) continue;
    const double* p = paramData(*this, id, i);
    const int n = paramSize(specs[i].shape);
    std::vector<double> out(static_cast<std::size_t>(n), 0.0);
    if (p) {
      for (int e = 0; e < n; ++e)
        out[static_cast<std::size_t>(e)] = p[storageOffset(specs[i].shape, e)];
    }
    return out;
  }
  return std::nullopt;
}

bool EffectSet::setParam(EffectId id, std::string_view name, std::span<const double> values,
                         std::string* why) {
  const auto specs = paramSpecs(id);
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    if (name != specs[i].name) continue;
    const int n = paramSize(specs[i].shape);
    if (static_cast<int>(values.size()) != n) {
      if (why) {
        *why = std::string(effectName(id)) + "." + specs[i].name + ": expected " +
               std::to_string(n) + " numbers, got " + std::to_string(values.size());
      }
      return false;
    }
    for (double v : values) {
      if (!std::isfinite(v)) {
        if (why) *why = std::string(effectName(id)) + "." + specs[i].name + ": non-finite value";
        return false;
      }
    }
    enable(id);
    double* p = paramData(*this, id, i);
    for (int e = 0; e < n; ++e) {
      p[storageOffset(specs[i].shape, e)] = values[static_cast<std::size_t>(e)];
    }
    return true;
  }
  if (why) {
    *why = std::string(effectName(id)) + ": unknown parameter '" + std::string(name) + "'";
  }
  return false;
}

Readings forwardReadings(const SensorModel& sensors, const EffectSet& fx, const PhysicsPoint& p) {
  // Inputs (frame B).
  Vec3 f = p.f_B;
  if (fx.lever_arm) f += fx.lever_arm->specificForceTerm(p.w_LB_B, p.wdot_LB_B);
  Vec3 w = p.w_IB_B;
  if (fx.gyro_g_sensitivity) w += fx.gyro_g_sensitivity->rateTerm(f);

  // Temperature-dependent bias and scale.
  Vec3 bias_a = sensors.accel.bias, bias_g = sensors.gyro.bias;
  Vec3 scale_a = sensors.accel.scale, scale_g = sensors.gyro.scale;
  if (fx.thermal_bias) {
    const double dT = p.temp_c - fx.thermal_bias->t_ref_c;
    bias_a += fx.thermal_bias->k_accel * dT;
    bias_g += fx.thermal_bias->k_gyro * dT;
  }
  if (fx.thermal_scale) {
    const double dT = p.temp_c - fx.thermal_scale->t_ref_c;
    scale_a = scale_a.cwiseProduct(Vec3::Ones() + fx.thermal_scale->k_accel * dT);
    scale_g = scale_g.cwiseProduct(Vec3::Ones() + fx.thermal_scale->k_gyro * dT);
  }

  Vec3 u_a = sensors.accel.M() * f;
  if (fx.accel_k2) u_a += fx.accel_k2->k2.cwiseProduct(u_a.cwiseProduct(u_a));
  u_a -= bias_a;
  const Vec3 u_g = sensors.gyro.M() * w - bias_g;

  Readings r;
  r.accel = scale_a.cwiseProduct(u_a);
  r.gyro = scale_g.cwiseProduct(u_g);
  if (fx.scale_asymmetry) r.gyro += fx.scale_asymmetry->gyro.cwiseProduct(u_g.cwiseAbs());
  return r;
}

Readings effectTerm(EffectId id, const SensorModel& sensors, const EffectSet& effects,
                    const PhysicsPoint& p) {
  EffectSet with = effects;
  with.enable(id);
  EffectSet without = effects;
  without.disable(id);
  const Readings a = forwardReadings(sensors, with, p);
  const Readings b = forwardReadings(sensors, without, p);
  return {a.accel - b.accel, a.gyro - b.gyro};
}

}  // namespace imubench::calib
