// The bench simulator: IMU increments and table encoder angles from a calib::Motion, the true
// site, table geometry/errors, sensor errors, extra effects and a noise model. The virtual
// bench and `imubench simulate` run it; the calibrators use it (noise off) as the forward model
// for increments.
//
// Physics at time t (tau = time_delay.tau_s, 0 if absent): the table state of the motion at
// t_phys = t - tau (the accelerometers at t_phys - accel_delay.tau_s); the encoder state made
// the true joint state by angle_harmonic; C_LB, w_LB_B, wdot_LB_B from the table chain
// (calib/model/table_chain.h through calib/table_model.h) with the truth's table errors plus
// the table effects (base_tilt, nonorthogonality, encoder_zero, mounting); f_B and w_IB_B from
// the model's bench physics (calib/model/bench_physics.h), then the reading effects and the
// sensor model (calib/effects.h forwardReadings). The true site is the given site shifted by
// the latitude_error / gravity_error effects. Every effect's term is its unit's in
// calib/model/effects/ (calib/effects.h lists them).
//
// Increments: sample k (k = 1, 2, ...) is stamped t_k = k / imu_rate_hz and integrates the
// readings over (t_k - tau - dt, t_k - tau]. The interval is split at every motion phase
// boundary inside it, and each smooth piece is integrated with Gauss-Legendre quadrature
// (SimOptions::quadrature_nodes, default 3: exact for polynomials of degree 5; for table rates
// w and accelerations the error of the rotation terms is ~ (w dt)^7/2016000 relative, i.e.
// < 1e-16 for 100 deg/s at 100 Hz). A piece where the table is still is evaluated at one
// node, exactly (readings are constant there, or linear in a linear temperature ramp).
// Noise: white noise N(0, white^2 dt) per increment and a Gauss-Markov bias (updated every
// SimOptions::bias_update_interval_s, held in between) times dt, both scaled by the truth scale
// factors; deterministic per seed. bias_instability adds a per-axis Gauss-Markov drift whose
// Allan deviation peaks at the given minimum at tau_s (calib/model/effects/noise.h),
// updated every sample from its own random stream (seed-derived), so switching it on changes
// nothing else. Temperature: Motion::temperatureAt(t_k - tau - dt/2).
// Thermal truth (BenchWorld::thermal): the sensor coefficients of each sample are those of
// calib/model/thermal_coefficients.h at the sample's temperature and its rate (the slope of the
// temperature history over +-0.5 s), held over the sample; they replace truth.sensors.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"
#include "calib/effects.h"
#include "calib/model/motion.h"
#include "calib/model/thermal_coefficients.h"
#include "calib/noise.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

// Everything about the simulated bench except its motion.
struct BenchWorld {
  nav::Site site;  // assumed site (truth = site + latitude_error/gravity_error effects)
  double outer_axis_heading_rad = kPi / 2.0;  // two-axis table: outer axis heading (East)
  BenchTruth truth;  // sensor errors, table errors (truth.table_kind ignored), extra effects
  NoiseModel noise;  // default: no noise
  // Temperature-dependent sensor coefficients (imubench-thermal/1 form); when set they replace
  // truth.sensors, evaluated at the IMU temperature of the motion (thermal lag included).
  std::optional<model::ThermalCoefficients> thermal;
};

struct SimulatorInput {
  BenchWorld world;
  Motion motion;  // its kind selects the table chain
};

struct SimOptions {
  double imu_rate_hz = 200.0;    // typical navigation-grade IMU output rate
  double table_rate_hz = 100.0;  // typical encoder logging rate of a rate table
  std::uint64_t seed = 1;        // noise seed; same seed -> identical samples
  int quadrature_nodes = 3;      // Gauss-Legendre nodes per smooth piece (1..5)
  // Gauss-Markov bias update step, s (rounded to whole samples, at least one): exact
  // discretisation at this step, held in between. Bias instability correlation times are
  // minutes to hours, so 10 ms changes nothing measurable and saves the draws at high rates.
  double bias_update_interval_s = 0.01;
  // Batch only: simulate until motion.duration (true) or until this time if > 0.
  double end_time_s = 0.0;

  bool IsValid(std::string* why) const;
};

// One encoder sample: what the table's encoders read (nominal angles of the motion), rad.
struct TableSample {
  double t = 0.0;  // s, table clock
  TableAngles angles;
};

struct Simulation {
  Status status = Status::Error("not simulated");  // why not (bad world, motion or options)
  TableKind kind = TableKind::kTwoAxis;
  nav::ImuSamples imu;
  std::vector<TableSample> table;
  std::vector<Segment> segments;  // copied from the motion
};

// Batch: all samples with t_k <= duration (motion.duration or options.end_time_s).
Simulation simulate(const SimulatorInput& input, const SimOptions& options);

// The true site: assumed site shifted by the world's latitude_error / gravity_error effects.
nav::Site trueSite(const nav::Site& assumed, const EffectSet& effects);

// Streaming simulator over a Motion that may still grow (the virtual bench appends axis
// phases as commands arrive). Holds the noise state; deterministic per seed. The Motion is
// referenced, not copied: keep it alive and only append to it (phases with t0 >= the physics
// time already simulated, or the past changes under the simulator).
class ImuSimulator {
 public:
  // Returns nullptr and sets *why if the world or options are invalid or the motion has the
  // wrong number of axes.
  static std::unique_ptr<ImuSimulator> Create(const BenchWorld& world, const Motion* motion,
                                              const SimOptions& options, std::string* why);

  // The next sample (stamp nextTime()); advances.
  nav::ImuSample next();
  // Stamp of the sample next() will return, s.
  double nextTime() const;
  // Physics time up to which next() needs the motion to be known: nextTime() - tau.
  double nextPhysicsEnd() const;
  // Encoder reading at table time t.
  TableSample tableAt(double t) const;
  // Samples produced so far.
  std::uint64_t count() const { return k_; }

  ~ImuSimulator();
  ImuSimulator(const ImuSimulator&) = delete;
  ImuSimulator& operator=(const ImuSimulator&) = delete;

 private:
  ImuSimulator() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint64_t k_ = 0;
};

}  // namespace imubench::calib
