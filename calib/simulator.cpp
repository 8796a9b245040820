#include "calib/simulator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "calib/model/bench_physics.h"
#include "calib/thermal_model.h"

namespace imubench::calib {
namespace {

// Gauss-Legendre nodes (on [-1, 1]) and weights for 1..5 nodes.
struct GaussRule {
  int n;
  std::array<double, 5> x;
  std::array<double, 5> w;
};
constexpr GaussRule kRules[] = {
    {1, {0.0}, {2.0}},
    {2, {-0.5773502691896257645, 0.5773502691896257645}, {1.0, 1.0}},
    {3,
     {-0.7745966692414833770, 0.0, 0.7745966692414833770},
     {0.5555555555555555556, 0.8888888888888888889, 0.5555555555555555556}},
    {4,
     {-0.8611363115940525752, -0.3399810435848562648, 0.3399810435848562648, 0.8611363115940525752},
     {0.3478548451374538574, 0.6521451548625461426, 0.6521451548625461426, 0.3478548451374538574}},
    {5,
     {-0.9061798459386639928, -0.5384693101056830910, 0.0, 0.5384693101056830910,
      0.9061798459386639928},
     {0.2369268850561890875, 0.4786286704993664680, 0.5688888888888888889, 0.4786286704993664680,
      0.2369268850561890875}},
};

constexpr int kMaxAxes = 3;

bool validTruth(const BenchTruth& t, std::string* why) {
  const auto finite = [](const Vec3& v) { return v.allFinite(); };
  for (const auto* tr : {&t.sensors.accel, &t.sensors.gyro}) {
    const char* name = tr == &t.sensors.accel ? "truth.accel" : "truth.gyro";
    if (!finite(tr->scale) || !finite(tr->bias) || (tr->scale.array() == 0.0).any()) {
      if (why) *why = std::string(name) + ": scale/bias must be finite, scale non-zero";
      return false;
    }
  }
  return true;
}

// A thermal truth must give finite coefficients and non-zero scales over its range.
bool validThermal(const std::optional<model::ThermalCoefficients>& c, std::string* why) {
  if (!c) return true;
  if (!(std::isfinite(c->t_min_c) && std::isfinite(c->t_max_c) && c->t_min_c <= c->t_max_c)) {
    if (why) *why = "thermal truth: range must be finite with t_min <= t_max";
    return false;
  }
  for (const double T : {c->t_min_c, c->t_ref_c, c->t_max_c}) {
    BenchTruth t;
    t.sensors = thermalSensorsAt(*c, T, 0.0);
    if (!validTruth(t, why)) {
      if (why) *why = "thermal truth at " + std::to_string(T) + " degC: " + *why;
      return false;
    }
  }
  return true;
}

// The effects the simulator cannot realise as given.
bool validEffects(const EffectSet& fx, TableKind kind, std::string* why) {
  if (fx.angle_harmonic && kind == TableKind::kTwoAxis &&
      fx.angle_harmonic->axis == kTableAxisMiddle) {
    if (why) *why = "extra.angle_harmonic.axis: a two-axis table has no middle axis";
    return false;
  }
  if (fx.bias_instability && !(fx.bias_instability->tau_s > 0.0)) {
    if (why) *why = "extra.bias_instability.tau_s must be > 0";
    return false;
  }
  return true;
}

// Per-axis Gauss-Markov drift of one triad (bias_instability): exact discretisation at the
// sample step, held over the sample.
struct DriftProcess {
  Vec3 b = Vec3::Zero();    // current drift, reading units
  Vec3 phi = Vec3::Zero();  // exp(-dt / T_c) per axis
  Vec3 q = Vec3::Zero();    // sigma sqrt(1 - phi^2) per axis
  bool active = false;

  void init(const Vec3& allan_min, const double* params, double dt, GaussianSource* rng) {
    for (int k = 0; k < 3; ++k) {
      double sigma = 0.0, t_c = 0.0;
      model::effects::BiasInstability::gaussMarkov(params, allan_min[k], &sigma, &t_c);
      phi[k] = std::exp(-dt / t_c);
      q[k] = sigma * std::sqrt(1.0 - phi[k] * phi[k]);
      b[k] = sigma * rng->next();  // stationary start
      active = active || sigma > 0.0;
    }
  }
  void step(GaussianSource* rng) {
    for (int k = 0; k < 3; ++k) b[k] = phi[k] * b[k] + q[k] * rng->next();
  }
};

// Seed offset of the drift's own random stream, so switching bias_instability on leaves the
// white noise and Gauss-Markov draws of the noise model unchanged.
constexpr std::uint64_t kDriftSeedOffset = 0x9E3779B97F4A7C15ull;

}  // namespace

nav::Site trueSite(const nav::Site& assumed, const EffectSet& effects) {
  nav::Site s = assumed;
  if (effects.latitude_error) {
    s.latitude_rad =
        model::effects::LatitudeError::trueValue(&effects.latitude_error->dlat_rad, s.latitude_rad);
  }
  if (effects.gravity_error) {
    s.gravity_mps2 = model::effects::GravityError::trueValue(&effects.gravity_error->dg_mps2,
                                                             nav::siteGravity(s));
  }
  return s;
}

bool SimOptions::IsValid(std::string* why) const {
  auto bad = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(std::isfinite(imu_rate_hz) && imu_rate_hz > 0.0)) return bad("imu_rate_hz must be > 0");
  if (!(std::isfinite(table_rate_hz) && table_rate_hz > 0.0)) {
    return bad("table_rate_hz must be > 0");
  }
  if (quadrature_nodes < 1 || quadrature_nodes > 5) return bad("quadrature_nodes must be 1..5");
  if (!(std::isfinite(end_time_s) && end_time_s >= 0.0)) return bad("end_time_s must be >= 0");
  if (!(std::isfinite(bias_update_interval_s) && bias_update_interval_s >= 0.0)) {
    return bad("bias_update_interval_s must be >= 0");
  }
  return true;
}

// ---- Streaming simulator ----------------------------------------------------------------

struct ImuSimulator::Impl {
  const Motion* motion = nullptr;
  TableModel table;
  SensorModel sensors;
  EffectSet effects;
  ForwardModel forward{SensorModel{}, EffectSet{}};  // sensors + reading effects, prepared
  NoiseModel noise;
  double gravity = 0.0;        // g of the true site
  Vec3 w_ie_L = Vec3::Zero();  // Earth rate of the true site
  double tau = 0.0;            // time_delay: physics of both triads at stamp - tau
  double tau_accel = 0.0;      // accel_delay: accelerometers a further tau_accel earlier
  bool angle_effects = false;  // angle_harmonic on: true joint states from the encoder's
  double dt = 0.0;
  double rate_hz = 0.0;
  GaussRule rule{};
  int n_axes = 0;
  std::array<std::size_t, kMaxAxes> cursor{};  // phase index with t0 <= current time
  GaussianSource rng{1};
  Vec3 gm_accel = Vec3::Zero();
  Vec3 gm_gyro = Vec3::Zero();
  double phi_accel = 0.0, q_accel = 0.0, phi_gyro = 0.0, q_gyro = 0.0;
  std::uint64_t gm_every = 1;   // samples per Gauss-Markov update
  GaussianSource drift_rng{1};  // bias_instability's own stream
  DriftProcess drift_accel, drift_gyro;
  std::optional<model::ThermalCoefficients> thermal;  // thermal truth (see simulator.h)
  double thermal_temp = std::numeric_limits<double>::quiet_NaN();  // (T, Tdot) of `forward`
  double thermal_rate = 0.0;

  // Thermal truth: the sensors at the temperature and rate of physics time t.
  void updateThermal(double t) {
    if (!thermal) return;
    const double T = motion->temperatureAt(t);
    // Backward over 1 s: a sample is made from the history up to its own time (the virtual
    // bench makes each one as it is due); the thermal lags (minutes) make the half-second
    // delay of this rate negligible.
    const double rate = motion->temperatureAt(t) - motion->temperatureAt(t - 1.0);
    if (T == thermal_temp && rate == thermal_rate) return;
    thermal_temp = T;
    thermal_rate = rate;
    sensors = thermalSensorsAt(*thermal, T, rate);
    forward = ForwardModel(sensors, effects);
  }

  // Phase of axis a in effect at time t (the cursor moves from where it is: forward as the
  // samples advance, back by at most a few phases for the accelerometers' earlier interval).
  const AxisPhase* phaseAt(int a, double t) {
    const auto& ph = motion->axes[static_cast<std::size_t>(a)].phases();
    if (ph.empty()) return nullptr;
    std::size_t& c = cursor[static_cast<std::size_t>(a)];
    while (c > 0 && ph[c].t0 > t) --c;
    while (c + 1 < ph.size() && ph[c + 1].t0 <= t) ++c;
    return &ph[c];
  }

  static AxisState stateOf(const AxisPhase* p, double t) {
    return p ? stateIn(*p, t) : AxisState{};
  }

  Readings readingsAt(const std::array<const AxisPhase*, kMaxAxes>& ph, double t) const {
    TableState s;
    if (n_axes == 2) {
      s.outer = stateOf(ph[0], t);
      s.inner = stateOf(ph[1], t);
    } else {
      s.outer = stateOf(ph[0], t);
      s.middle = stateOf(ph[1], t);
      s.inner = stateOf(ph[2], t);
    }
    if (angle_effects) s = trueTableState(s, effects);
    const TableKinematics k = table.kinematics(s);
    const model::Physics<double> m = model::benchPhysics(k, gravity, w_ie_L);
    PhysicsPoint p{m.f_B, m.w_IB_B, m.w_LB_B, m.wdot_LB_B};
    p.temp_c = motion->temperature.empty() ? 20.0 : motion->temperatureAt(t);
    return forward.readings(p);
  }

  // Integral of the readings over the smooth piece [a, b] (no phase starts inside); a null
  // dtheta or dvel skips that triad.
  void integratePiece(double a, double b, Vec3* dtheta, Vec3* dvel) {
    if (b <= a) return;
    const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
    std::array<const AxisPhase*, kMaxAxes> ph{};
    bool still = true;
    for (int i = 0; i < n_axes; ++i) {
      ph[static_cast<std::size_t>(i)] = phaseAt(i, mid);
      const AxisPhase* p = ph[static_cast<std::size_t>(i)];
      if (p && mid >= p->t0 && (p->rate0 != 0.0 || p->accel != 0.0)) still = false;
    }
    const auto add = [&](const Readings& r, double w) {
      if (dtheta) *dtheta += w * r.gyro;
      if (dvel) *dvel += w * r.accel;
    };
    if (still) {
      add(readingsAt(ph, mid), b - a);
      return;
    }
    for (int n = 0; n < rule.n; ++n) {
      add(readingsAt(ph, mid + half * rule.x[static_cast<std::size_t>(n)]),
          half * rule.w[static_cast<std::size_t>(n)]);
    }
  }

  // Integral over (a, b], split at every phase start inside.
  void integrate(double a, double b, Vec3* dtheta, Vec3* dvel) {
    // Bring the cursors to a.
    for (int i = 0; i < n_axes; ++i) phaseAt(i, a);
    double t = a;
    while (t < b) {
      double next = b;
      for (int i = 0; i < n_axes; ++i) {
        const auto& ph = motion->axes[static_cast<std::size_t>(i)].phases();
        std::size_t c = cursor[static_cast<std::size_t>(i)];
        while (c < ph.size() && ph[c].t0 <= t) ++c;
        if (c < ph.size() && ph[c].t0 < next) next = ph[c].t0;
      }
      integratePiece(t, next, dtheta, dvel);
      t = next;
    }
  }
};

std::unique_ptr<ImuSimulator> ImuSimulator::Create(const BenchWorld& world, const Motion* motion,
                                                   const SimOptions& options, std::string* why) {
  if (!motion) {
    if (why) *why = "no motion given";
    return nullptr;
  }
  if (!options.IsValid(why) || !world.noise.IsValid(why) || !validTruth(world.truth, why) ||
      !validThermal(world.thermal, why) || !validEffects(world.truth.extra, motion->kind, why)) {
    return nullptr;
  }
  if (static_cast<int>(motion->axes.size()) != axisCount(motion->kind)) {
    if (why) {
      *why = "motion has " + std::to_string(motion->axes.size()) + " axes, the " +
             (motion->kind == TableKind::kTwoAxis ? "two" : "three") + "-axis table needs " +
             std::to_string(axisCount(motion->kind));
    }
    return nullptr;
  }
  if (!std::isfinite(world.site.latitude_rad) || !std::isfinite(world.site.height_m) ||
      !std::isfinite(world.outer_axis_heading_rad)) {
    if (why) *why = "site latitude/height and outer axis heading must be finite";
    return nullptr;
  }
  std::unique_ptr<ImuSimulator> sim(new ImuSimulator());
  auto impl = std::make_unique<Impl>();
  impl->motion = motion;
  TableGeometry geometry{motion->kind, world.outer_axis_heading_rad};
  impl->table = TableModel(geometry, tableErrorsWithEffects(world.truth.table, world.truth.extra));
  impl->sensors = world.truth.sensors;
  impl->effects = world.truth.extra;
  impl->forward = ForwardModel(world.truth.sensors, world.truth.extra);
  impl->noise = world.noise;
  impl->thermal = world.thermal;
  const nav::Site site = trueSite(world.site, world.truth.extra);
  impl->gravity = nav::siteGravity(site);
  impl->w_ie_L = nav::earthRateL(site.latitude_rad);
  impl->tau = -gyroPhysicsTime(0.0, world.truth.extra);
  impl->tau_accel =
      gyroPhysicsTime(0.0, world.truth.extra) - accelPhysicsTime(0.0, world.truth.extra);
  impl->angle_effects = world.truth.extra.angle_harmonic.has_value();
  impl->rate_hz = options.imu_rate_hz;
  impl->dt = 1.0 / options.imu_rate_hz;
  impl->rule = kRules[options.quadrature_nodes - 1];
  impl->n_axes = axisCount(motion->kind);
  impl->rng = GaussianSource(options.seed);
  const double dt = impl->dt;
  impl->gm_every =
      static_cast<std::uint64_t>(std::max(1.0, std::round(options.bias_update_interval_s / dt)));
  const double gm_step = static_cast<double>(impl->gm_every) * dt;
  impl->phi_accel = std::exp(-gm_step / world.noise.accel.correlation_time_s);
  impl->phi_gyro = std::exp(-gm_step / world.noise.gyro.correlation_time_s);
  impl->q_accel = world.noise.accel.bias_sigma * std::sqrt(1.0 - impl->phi_accel * impl->phi_accel);
  impl->q_gyro = world.noise.gyro.bias_sigma * std::sqrt(1.0 - impl->phi_gyro * impl->phi_gyro);
  // Gauss-Markov biases start in their steady state.
  if (world.noise.gyro.bias_sigma > 0.0)
    impl->gm_gyro = world.noise.gyro.bias_sigma * impl->rng.next3();
  if (world.noise.accel.bias_sigma > 0.0) {
    impl->gm_accel = world.noise.accel.bias_sigma * impl->rng.next3();
  }
  if (world.truth.extra.bias_instability) {
    const BiasInstability& bi = *world.truth.extra.bias_instability;
    const double block[] = {bi.accel.x(), bi.accel.y(), bi.accel.z(), bi.gyro.x(),
                            bi.gyro.y(),  bi.gyro.z(),  bi.tau_s};
    impl->drift_rng = GaussianSource(options.seed + kDriftSeedOffset);
    impl->drift_accel.init(bi.accel, block, dt, &impl->drift_rng);
    impl->drift_gyro.init(bi.gyro, block, dt, &impl->drift_rng);
  }
  sim->impl_ = std::move(impl);
  return sim;
}

ImuSimulator::~ImuSimulator() = default;

double ImuSimulator::nextTime() const {
  return static_cast<double>(k_ + 1) / impl_->rate_hz;
}

double ImuSimulator::nextPhysicsEnd() const {
  return nextTime() - impl_->tau - std::min(0.0, impl_->tau_accel);
}

nav::ImuSample ImuSimulator::next() {
  Impl& m = *impl_;
  ++k_;
  nav::ImuSample s;
  s.t = static_cast<double>(k_) / m.rate_hz;
  const double b = s.t - m.tau;
  const double a = static_cast<double>(k_ - 1) / m.rate_hz - m.tau;
  m.updateThermal(0.5 * (a + b));
  if (m.tau_accel == 0.0) {
    m.integrate(a, b, &s.dtheta, &s.dvel);
  } else {
    m.integrate(a, b, &s.dtheta, nullptr);
    m.integrate(a - m.tau_accel, b - m.tau_accel, nullptr, &s.dvel);
  }
  const double dt = b - a;
  if (m.drift_gyro.active || m.drift_accel.active) {
    s.dtheta += dt * m.drift_gyro.b;
    s.dvel += dt * m.drift_accel.b;
    m.drift_gyro.step(&m.drift_rng);
    m.drift_accel.step(&m.drift_rng);
  }
  const NoiseModel& n = m.noise;
  const bool update_gm = k_ % m.gm_every == 0;
  if (n.gyro.white > 0.0 || n.gyro.bias_sigma > 0.0) {
    Vec3 e = m.gm_gyro * dt;
    if (n.gyro.white > 0.0) e += (n.gyro.white * std::sqrt(dt)) * m.rng.next3();
    s.dtheta += m.sensors.gyro.scale.cwiseProduct(e);
    if (update_gm && n.gyro.bias_sigma > 0.0)
      m.gm_gyro = m.phi_gyro * m.gm_gyro + m.q_gyro * m.rng.next3();
  }
  if (n.accel.white > 0.0 || n.accel.bias_sigma > 0.0) {
    Vec3 e = m.gm_accel * dt;
    if (n.accel.white > 0.0) e += (n.accel.white * std::sqrt(dt)) * m.rng.next3();
    s.dvel += m.sensors.accel.scale.cwiseProduct(e);
    if (update_gm && n.accel.bias_sigma > 0.0) {
      m.gm_accel = m.phi_accel * m.gm_accel + m.q_accel * m.rng.next3();
    }
  }
  s.temp_c = m.motion->temperatureAt(0.5 * (a + b));
  return s;
}

TableSample ImuSimulator::tableAt(double t) const {
  const TableState st = tableStateAt(*impl_->motion, t);
  return {t, st.angles()};
}

// ---- Batch ------------------------------------------------------------------------------

Simulation simulate(const SimulatorInput& input, const SimOptions& options) {
  Simulation out;
  out.kind = input.motion.kind;
  std::string why;
  auto sim = ImuSimulator::Create(input.world, &input.motion, options, &why);
  if (!sim) {
    out.status = Status::Error(why);
    return out;
  }
  const double end = options.end_time_s > 0.0 ? options.end_time_s : input.motion.duration;
  if (!(std::isfinite(end) && end >= 0.0)) {
    out.status = Status::Error("motion duration must be finite and >= 0");
    return out;
  }
  // Stamps k / rate <= end (with a relative tolerance so an exact end is included).
  const auto n_imu = static_cast<std::uint64_t>(std::floor(end * options.imu_rate_hz + 1e-9));
  out.imu.reserve(n_imu);
  for (std::uint64_t k = 0; k < n_imu; ++k) out.imu.push_back(sim->next());
  const auto n_table = static_cast<std::uint64_t>(std::floor(end * options.table_rate_hz + 1e-9));
  out.table.reserve(n_table + 1);
  for (std::uint64_t j = 0; j <= n_table; ++j) {
    out.table.push_back(sim->tableAt(static_cast<double>(j) / options.table_rate_hz));
  }
  out.segments = input.motion.segments;
  out.status = Status::Ok();
  return out;
}

}  // namespace imubench::calib
