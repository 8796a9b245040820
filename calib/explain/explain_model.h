// The recording as the model-discrepancy analysis (calib/explain/explain.h) sees it, and the
// forward model's prediction of it.
//
// Windows ("bins"): consecutive IMU samples grouped into spans of about ExplainModelOptions::
// bin_s, never across a segment boundary. A bin's measurement is the mean reading over the
// span it covers (sum of the increments / duration), per channel. Its prediction is the mean
// of the forward model's readings over the same span, integrated with Gauss-Legendre nodes
// (two per encoder interval while the table moves, so the encoder interpolation's pieces are
// integrated exactly; three over the whole bin while it is still). Readings, prediction and
// every regressor are integrals over the same spans, so the linear relations between them hold
// exactly whatever the bin length: the bin length sets resolution and cost only.
//
// Table kinematics: a natural cubic spline per axis through the encoder angles (unwrapped),
// differentiated for rate and acceleration: any encoder rate and timing, no motion profile
// assumed. The model at a node is the library's: table chain (calib/table_model.h) -> bench
// physics (calib/model/bench_physics.h) -> effects and sensor equation (calib/effects.h
// forwardReadings). Effects that act on time or site rather than on the readings are applied
// where the simulator applies them: time_delay (and accel_delay, when the registry has it)
// shifts the physics time, latitude_error / gravity_error shift the site (trueSite).
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/effects.h"
#include "calib/simulator.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

struct ExplainBin {
  double t0 = 0.0;                   // s, start of the first sample interval
  double t1 = 0.0;                   // s, end of the last
  int segment = -1;                  // index into the segments, -1 outside all
  bool moving = false;               // the table turns inside the bin
  std::array<double, 6> measured{};  // mean readings: accel x,y,z (m/s^2), gyro x,y,z (rad/s)
  double temp_c = 20.0;              // mean sensor temperature
  // Encoder-interpolation uncertainty (see prepareExplainData): rad, root-sum-square over the
  // axes, of the angle at the bin's ends and the largest inside it.
  double angle_err_ends = 0.0;
  double angle_err_inside = 0.0;
  std::size_t node_begin = 0, node_end = 0;  // its quadrature nodes
  double duration() const { return t1 - t0; }
};

struct QuadratureNode {
  double t = 0.0;       // s, recording clock
  double weight = 0.0;  // fraction of the bin's mean (weights of a bin sum to 1)
  double temp_c = 20.0;
};

struct ExplainModelOptions {
  // Bin length, s: long enough to average the white noise of one sample, short against the
  // structure to resolve (a 30 deg/s run turns 15 deg in 0.5 s).
  double bin_s = 0.5;
  bool IsValid(std::string* why) const;
};

// Encoder angles of one axis as a natural cubic spline (angles unwrapped, rad).
class AxisSpline {
 public:
  AxisSpline() = default;
  AxisSpline(std::vector<double> t, std::vector<double> angle);
  // Angle, rate and acceleration at t (held at the ends outside the samples).
  AxisState at(double t) const;
  const std::vector<double>& knots() const { return t_; }
  const std::vector<double>& values() const { return y_; }

 private:
  std::vector<double> t_, y_, m_;  // knots, values, second derivatives
};

// The recording prepared for prediction: bins, nodes, table splines, site and geometry.
struct ExplainData {
  TableGeometry geometry;
  nav::Site site;
  std::vector<ExplainBin> bins;
  std::vector<QuadratureNode> nodes;
  std::vector<AxisSpline> axes;  // axisCount(kind) splines
  // Scatter of the encoder samples' time stamps, s (encoderTimeSigma): a reading stamped by a
  // host that polls the controller stands anywhere within the poll's round trip.
  double stamp_sigma_s = 0.0;
};

// The scatter of the encoder samples' time stamps, estimated from the samples themselves:
// while an axis turns, each sample is compared with the cubic through its two neighbours on
// either side (smooth motion: far below the scatter), and the difference divided by the rate
// is a time error; a robust (median) deviation over all moving samples, scaled for the
// neighbours' own errors. 0 without enough moving samples (fewer than 20).
double encoderTimeSigma(const std::vector<AxisSpline>& axes);

// Builds bins and nodes. Samples must be checked (finite, increasing) by the caller. Samples
// outside the span of the encoder samples are left out (no kinematics there).
// Interpolation uncertainty: the spline through every encoder sample is compared with the
// spline through every second one; near an acceleration step the error grows with the knot
// spacing squared, so a third of their difference estimates the finer spline's error (and
// over-estimates it where the motion is smooth, where both are tiny); a moving axis adds its
// rate times the time stamps' scatter (encoderTimeSigma).
ExplainData prepareExplainData(const TableGeometry& geometry, const nav::Site& site,
                               std::span<const nav::ImuSample> imu,
                               std::span<const TableSample> table,
                               std::span<const Segment> segments,
                               const ExplainModelOptions& options);

// What a fit varies: the full model (sensors, table errors, extra effects) and nuisance
// parameters of the recording (e.g. the unknown attitudes of hand-placed poses), addressed by
// flat name: bench_truth.h names, or "nuisance.N".
struct ExplainState {
  BenchTruth model;
  std::vector<double> nuisance;
};
double stateValue(const ExplainState& s, const std::string& name);
bool setStateValue(ExplainState* s, const std::string& name, double value, std::string* why);

// A forward model of the bins: mean readings of every bin (6 per bin, bin-major).
class ExplainForward {
 public:
  virtual ~ExplainForward() = default;
  virtual void predict(const ExplainState& state, std::vector<double>* out) = 0;
  // An independent copy for another thread (its own caches; what it reads of the recording
  // shared), or nullptr: then the Jacobian's columns are computed on one thread.
  virtual std::unique_ptr<ExplainForward> clone() const { return nullptr; }
};

// The table recording's forward model: the library's chain, physics and sensor equation
// along the encoder spline. Keeps the table physics of the last call: a model that only
// changes sensor or reading-level effect parameters reuses it.
class ExplainPredictor : public ExplainForward {
 public:
  explicit ExplainPredictor(const ExplainData* data) : data_(data) {}
  void predict(const ExplainState& state, std::vector<double>* out) override;
  std::unique_ptr<ExplainForward> clone() const override {
    return std::make_unique<ExplainPredictor>(*this);
  }

 private:
  struct PhysicsKey {
    std::array<double, 13> table{};
    double latitude = 0.0, gravity = 0.0, tau = 0.0, tau_accel = 0.0;
    std::array<double, 4> harmonic{-1.0, 0.0, 0.0, 0.0};  // angle_harmonic: axis (-1 off) .. sin
    bool operator==(const PhysicsKey&) const = default;
  };
  PhysicsKey keyOf(const BenchTruth& model) const;
  void computePhysics(const BenchTruth& model, const PhysicsKey& key);
  PhysicsPoint physicsAt(const TableModel& table, const EffectSet& extra, double gravity,
                         const Vec3& w_ie_L, double t, double temp_c) const;

  const ExplainData* data_;
  bool have_physics_ = false;
  PhysicsKey key_;
  std::vector<PhysicsPoint> physics_;        // per node (gyro and, without accel delay, accel)
  std::vector<PhysicsPoint> accel_physics_;  // per node when the accelerometers are delayed
};

// Time shifts of the model's timing effects, s: time_delay.tau_s and accel_delay.tau_s (0 when
// the effect is disabled or not in the registry).
double timeDelayOf(const EffectSet& effects);
double accelDelayOf(const EffectSet& effects);

}  // namespace imubench::calib
