#include "calib/effects.h"

#include <charconv>
#include <cmath>
#include <type_traits>

namespace imubench::calib {
namespace {

// ---- Storage of every effect in EffectSet: the one table of members ---------------------

double* dataOf(double& v) {
  return &v;
}
double* dataOf(Vec3& v) {
  return v.data();
}
double* dataOf(Mat3& m) {
  return m.data();
}  // column-major; storageOffset maps row-major

// The optional member of EffectSet holding an effect, and its parameters' fields in the
// order of the unit's parameters (its row of kUnitRows, calib/model/effects.h).
template <auto Member, auto... Fields>
struct Storage {
  static bool has(const EffectSet& s) { return (s.*Member).has_value(); }
  static void enable(EffectSet& s) {
    if (!(s.*Member)) (s.*Member).emplace();
  }
  static void disable(EffectSet& s) { (s.*Member).reset(); }
  static double* data(EffectSet& s, int param) {
    auto& o = s.*Member;
    if (!o) return nullptr;
    double* fields[] = {dataOf((*o).*Fields)...};
    return fields[param];
  }
};

struct StorageEntry {
  EffectId id;
  int param_count;
  bool (*has)(const EffectSet&);
  void (*enable)(EffectSet&);
  void (*disable)(EffectSet&);
  double* (*data)(EffectSet&, int);
};

template <auto Member, auto... Fields>
constexpr StorageEntry entry(EffectId id) {
  using S = Storage<Member, Fields...>;
  return {id, static_cast<int>(sizeof...(Fields)), &S::has, &S::enable, &S::disable, &S::data};
}

using E = EffectSet;
constexpr StorageEntry kStorage[] = {
    entry<&E::lever_arm, &LeverArm::r_m>(EffectId::kLeverArm),
    entry<&E::time_delay, &TimeDelay::tau_s>(EffectId::kTimeDelay),
    entry<&E::gyro_g_sensitivity, &GyroGSensitivity::G>(EffectId::kGyroGSensitivity),
    entry<&E::thermal_bias, &ThermalBias::k_accel, &ThermalBias::k_gyro, &ThermalBias::t_ref_c>(
        EffectId::kThermalBias),
    entry<&E::thermal_scale, &ThermalScale::k_accel, &ThermalScale::k_gyro, &ThermalScale::t_ref_c>(
        EffectId::kThermalScale),
    entry<&E::scale_asymmetry, &ScaleAsymmetry::gyro>(EffectId::kScaleAsymmetry),
    entry<&E::accel_k2, &AccelK2::k2>(EffectId::kAccelK2),
    entry<&E::latitude_error, &LatitudeError::dlat_rad>(EffectId::kLatitudeError),
    entry<&E::gravity_error, &GravityError::dg_mps2>(EffectId::kGravityError),
    entry<&E::size_effect, &SizeEffect::d_y_m, &SizeEffect::d_z_m>(EffectId::kSizeEffect),
    entry<&E::accel_delay, &AccelDelay::tau_s>(EffectId::kAccelDelay),
    entry<&E::angle_harmonic, &AngleHarmonic::axis, &AngleHarmonic::order, &AngleHarmonic::cos_rad,
          &AngleHarmonic::sin_rad>(EffectId::kAngleHarmonic),
    entry<&E::bias_instability, &BiasInstability::accel, &BiasInstability::gyro,
          &BiasInstability::tau_s>(EffectId::kBiasInstability),
    entry<&E::base_tilt, &BaseTilt::x, &BaseTilt::y>(EffectId::kBaseTilt),
    entry<&E::nonorthogonality, &Nonorthogonality::inner_y, &Nonorthogonality::middle_x,
          &Nonorthogonality::middle_y>(EffectId::kNonorthogonality),
    entry<&E::encoder_zero, &EncoderZero::outer, &EncoderZero::middle, &EncoderZero::inner>(
        EffectId::kEncoderZero),
    entry<&E::mounting, &Mounting::x, &Mounting::y>(EffectId::kMounting),
};
static_assert(std::size(kStorage) == kEffectCount, "every effect has its EffectSet member");

constexpr bool storageMatchesRegistry() {
  for (int i = 0; i < kEffectCount; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (kStorage[k].id != model::kUnitInfos[k].id) return false;
    if (kStorage[k].param_count != static_cast<int>(model::kUnitInfos[k].params.size())) {
      return false;
    }
  }
  return true;
}
static_assert(storageMatchesRegistry(), "kStorage: registry order, one field per parameter");

const StorageEntry& storageOf(EffectId id) {
  return kStorage[static_cast<std::size_t>(id)];
}
const model::UnitInfo& unitOf(EffectId id) {
  return model::kUnitInfos[static_cast<std::size_t>(id)];
}

double* paramData(EffectSet& s, EffectId id, int index) {
  return storageOf(id).data(s, index);
}
const double* paramData(const EffectSet& s, EffectId id, int index) {
  // The storage accessor only forms a pointer; the const overload never writes through it.
  return storageOf(id).data(const_cast<EffectSet&>(s), index);
}

// Element `e` of a parameter in flat (row-major for matrices) order -> storage offset.
int storageOffset(ParamShape shape, int e) {
  if (shape != ParamShape::kMat3) return e;
  const int row = e / 3, col = e % 3;
  return col * 3 + row;  // Eigen column-major
}

const char* const kVecComponents[] = {"x", "y", "z"};
const char* const kMatComponents[] = {"xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"};
const char* const kTableAxisNames[] = {"outer", "middle", "inner"};
// Upper bound of an integer parameter (a harmonic order): far beyond any physical one, and
// keeps cos(k a) meaningful in double.
constexpr double kMaxIntegerParam = 1e6;

// Why a value does not fit its parameter, or "" when it does.
std::string valueProblem(const ParamSpec& spec, double v) {
  if (!std::isfinite(v)) return "non-finite value";
  switch (spec.kind) {
    case ParamKind::kReal:
      return "";
    case ParamKind::kInteger:
      if (v != std::floor(v) || v < 1.0 || v > kMaxIntegerParam) {
        return "expected an integer >= 1";
      }
      return "";
    case ParamKind::kTableAxis:
      if (v != kTableAxisOuter && v != kTableAxisMiddle && v != kTableAxisInner) {
        return "expected a table axis (outer, middle, inner)";
      }
      return "";
  }
  return "";
}

}  // namespace

const char* effectName(EffectId id) {
  return unitOf(id).name;
}

std::optional<EffectId> effectFromName(std::string_view name) {
  for (EffectId id : kAllEffects) {
    if (name == effectName(id)) return id;
  }
  return std::nullopt;
}

model::Stage effectStage(EffectId id) {
  return unitOf(id).stage;
}
const char* effectTermText(EffectId id) {
  return unitOf(id).term;
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
  return unitOf(id).params;
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

const char* tableAxisName(int axis) {
  return axis >= kTableAxisOuter && axis <= kTableAxisInner
             ? kTableAxisNames[static_cast<std::size_t>(axis)]
             : "?";
}

std::optional<int> tableAxisFromName(std::string_view name) {
  for (int a = kTableAxisOuter; a <= kTableAxisInner; ++a) {
    if (name == kTableAxisNames[static_cast<std::size_t>(a)]) return a;
  }
  return std::nullopt;
}

bool EffectSet::has(EffectId id) const {
  return storageOf(id).has(*this);
}

void EffectSet::enable(EffectId id) {
  storageOf(id).enable(*this);
}

void EffectSet::disable(EffectId id) {
  storageOf(id).disable(*this);
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
    const int n = paramSize(specs[static_cast<std::size_t>(i)].shape);
    for (int e = 0; e < n; ++e) {
      out.push_back(p ? p[storageOffset(specs[static_cast<std::size_t>(i)].shape, e)] : 0.0);
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
  const auto specs = paramSpecs(id);
  std::size_t k = 0;
  for (const ParamSpec& spec : specs) {
    for (int e = 0; e < paramSize(spec.shape); ++e, ++k) {
      const std::string problem = valueProblem(spec, values[k]);
      if (!problem.empty()) {
        if (why) *why = std::string(effectName(id)) + "." + spec.name + ": " + problem;
        return false;
      }
    }
  }
  enable(id);
  k = 0;
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    double* p = paramData(*this, id, i);
    const int n = paramSize(specs[static_cast<std::size_t>(i)].shape);
    for (int e = 0; e < n; ++e) {
      p[storageOffset(specs[static_cast<std::size_t>(i)].shape, e)] = values[k++];
    }
  }
  return true;
}

std::optional<std::vector<double>> EffectSet::param(EffectId id, std::string_view name) const {
  const auto specs = paramSpecs(id);
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    const ParamSpec& spec = specs[static_cast<std::size_t>(i)];
    if (name != spec.name) continue;
    const double* p = paramData(*this, id, i);
    const int n = paramSize(spec.shape);
    std::vector<double> out(static_cast<std::size_t>(n), 0.0);
    if (p) {
      for (int e = 0; e < n; ++e)
        out[static_cast<std::size_t>(e)] = p[storageOffset(spec.shape, e)];
    }
    return out;
  }
  return std::nullopt;
}

bool EffectSet::setParam(EffectId id, std::string_view name, std::span<const double> values,
                         std::string* why) {
  const auto specs = paramSpecs(id);
  for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
    const ParamSpec& spec = specs[static_cast<std::size_t>(i)];
    if (name != spec.name) continue;
    const int n = paramSize(spec.shape);
    const std::string where = std::string(effectName(id)) + "." + spec.name;
    if (static_cast<int>(values.size()) != n) {
      if (why) {
        *why = where + ": expected " + std::to_string(n) + " numbers, got " +
               std::to_string(values.size());
      }
      return false;
    }
    for (double v : values) {
      const std::string problem = valueProblem(spec, v);
      if (!problem.empty()) {
        if (why) *why = std::string(where).append(": ").append(problem);
        return false;
      }
    }
    enable(id);
    double* p = paramData(*this, id, i);
    for (int e = 0; e < n; ++e)
      p[storageOffset(spec.shape, e)] = values[static_cast<std::size_t>(e)];
    return true;
  }
  if (why) {
    *why = std::string(effectName(id)) + ": unknown parameter '" + std::string(name) + "'";
  }
  return false;
}

bool setEffectParamFromText(EffectSet* effects, std::string_view text, std::string* why) {
  const auto fail = [&](const std::string& msg) {
    if (why) *why = "'" + std::string(text) + "': " + msg;
    return false;
  };
  const std::size_t eq = text.find('=');
  const std::string_view key = text.substr(0, eq);
  const std::size_t dot = key.find('.');
  if (eq == std::string_view::npos || dot == std::string_view::npos) {
    return fail("expected <effect>.<parameter>=<value>[,<value>...]");
  }
  const std::optional<EffectId> id = effectFromName(key.substr(0, dot));
  if (!id) return fail("unknown effect id '" + std::string(key.substr(0, dot)) + "'");
  const std::string_view name = key.substr(dot + 1);
  const ParamSpec* spec = nullptr;
  for (const ParamSpec& p : paramSpecs(*id)) {
    if (name == p.name) spec = &p;
  }
  if (!spec) return fail("unknown parameter '" + std::string(name) + "'");
  std::vector<double> values;
  std::string_view rest = text.substr(eq + 1);
  while (true) {
    const std::size_t comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    double v = 0.0;
    if (spec->kind == ParamKind::kTableAxis) {
      const std::optional<int> axis = tableAxisFromName(item);
      if (!axis) return fail("'" + std::string(item) + "' is not outer, middle or inner");
      v = *axis;
    } else {
      const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
      if (r.ec != std::errc() || r.ptr != item.data() + item.size()) {
        return fail("'" + std::string(item) + "' is not a number");
      }
    }
    values.push_back(v);
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  std::string err;
  if (!effects->setParam(*id, name, values, &err)) return fail(err);
  return true;
}

model::EffectBlocks<double> EffectBlockStore::blocks() const {
  model::EffectBlocks<double> b{};
  for (std::size_t k = 0; k < b.size(); ++k) b[k] = on[k] ? values[k].data() : nullptr;
  return b;
}

EffectBlockStore effectBlocks(const EffectSet& effects) {
  EffectBlockStore store;
  for (EffectId id : kAllEffects) {
    if (!effects.has(id)) continue;
    const auto k = static_cast<std::size_t>(id);
    store.on[k] = true;
    const auto specs = paramSpecs(id);
    std::size_t n = 0;
    for (int i = 0; i < static_cast<int>(specs.size()); ++i) {
      const ParamShape shape = specs[static_cast<std::size_t>(i)].shape;
      const double* p = paramData(effects, id, i);
      for (int e = 0; e < paramSize(shape); ++e) store.values[k][n++] = p[storageOffset(shape, e)];
    }
  }
  return store;
}

ForwardModel::ForwardModel(const SensorModel& sensors, const EffectSet& effects)
    : accel_(model::triadCoefficients(sensors.accel.block().data())),
      gyro_(model::triadCoefficients(sensors.gyro.block().data())),
      effects_(effectBlocks(effects)),
      blocks_(effects_.blocks()) {}

ForwardModel::ForwardModel(const ForwardModel& other)
    : accel_(other.accel_),
      gyro_(other.gyro_),
      effects_(other.effects_),
      blocks_(effects_.blocks()) {}

ForwardModel& ForwardModel::operator=(const ForwardModel& other) {
  accel_ = other.accel_;
  gyro_ = other.gyro_;
  effects_ = other.effects_;
  blocks_ = effects_.blocks();
  return *this;
}

// flatten: the templated model's helpers (tiny Eigen products, one per effect unit) are
// inlined into this double entry point, which the -O2 heuristics leave as calls (issue 31).
[[gnu::flatten]] Readings ForwardModel::readings(const PhysicsPoint& p) const {
  model::ReadingState<double> s;
  s.f_B = p.f_B;
  s.w_IB_B = p.w_IB_B;
  s.w_LB_B = p.w_LB_B;
  s.wdot_LB_B = p.wdot_LB_B;
  s.temp_c = p.temp_c;
  model::sensorReadings(accel_, gyro_, blocks_, &s);
  return {s.accel, s.gyro};
}

Readings forwardReadings(const SensorModel& sensors, const EffectSet& effects,
                         const PhysicsPoint& p) {
  return ForwardModel(sensors, effects).readings(p);
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

TableErrors tableErrorsWithEffects(const TableErrors& errors, const EffectSet& effects) {
  auto axes = axesBlock(errors);
  auto device = deviceBlock(errors);
  model::addTableEffects(effectBlocks(effects).blocks(), axes.data(), device.data());
  TableErrors out;
  out.base_tilt = Vec2(axes[model::kTiltX], axes[model::kTiltY]);
  out.nonorthogonality = {axes[model::kNonorthInnerY], axes[model::kNonorthMiddleX],
                          axes[model::kNonorthMiddleY]};
  out.mounting = Vec2(device[model::kMountX], device[model::kMountY]);
  out.encoder_zero = {device[model::kZeroOuter], device[model::kZeroMiddle],
                      device[model::kZeroInner]};
  return out;
}

TableState trueTableState(const TableState& encoder, const EffectSet& effects) {
  const auto joint = [](const AxisState& a) {
    return model::JointState<double>{a.angle, a.rate, a.accel};
  };
  const auto axis = [](const model::JointState<double>& j) {
    return AxisState{j.angle, j.rate, j.accel};
  };
  std::array<model::JointState<double>, 3> joints = {joint(encoder.outer), joint(encoder.middle),
                                                     joint(encoder.inner)};
  model::trueJointStates(effectBlocks(effects).blocks(), &joints);
  TableState out;
  out.outer = axis(joints[kTableAxisOuter]);
  out.middle = axis(joints[kTableAxisMiddle]);
  out.inner = axis(joints[kTableAxisInner]);
  return out;
}

double gyroPhysicsTime(double t_stamp, const EffectSet& effects) {
  if (!effects.time_delay) return t_stamp;
  return model::effects::TimeDelay::sampleTime(&effects.time_delay->tau_s, t_stamp);
}

double accelPhysicsTime(double t_stamp, const EffectSet& effects) {
  const double t_gyro = gyroPhysicsTime(t_stamp, effects);
  if (!effects.accel_delay) return t_gyro;
  return model::effects::AccelDelay::sampleTime(&effects.accel_delay->tau_s, t_gyro);
}

}  // namespace imubench::calib
