// Navigation-based (indirect) calibration, as in the seed paper (Ivshina 2024): a strapdown
// attitude solution started from the table setting (no aiding) is carried through every
// rotation about a horizontal axis on data compensated with the current coefficients; the
// residuals are the horizontal apparent accelerations in L at the holds (start/end of every
// run) and the change of the horizontal apparent acceleration over each run. A joint
// least-squares refinement in Ceres estimates both triads' coefficients AND the table base
// tilt. See docs/calibration.md for the residual model and the frame convention.
//
// Frame convention ("gyro-referenced"): all coefficients refer to the platform frame P that
// the table's orthogonal axes define (C_LP = nominal chain of the encoder angles). The gyro
// triad's misalignments are measured against the table's rotation axes, and the
// accelerometers' against the same frame, so the device mounting (beta', gamma'; not
// observable by this method) is absorbed by both triads' misalignments in one definite way:
//     M_est = M_true * E^T,  E = Rz(i0) (I + [mu x])  (mu = mounting, i0 = inner encoder zero).
// The base tilt (beta_oc, gamma_oc) and the axis nonorthogonality are estimated; the outer
// encoder zero of a two-axis table is indistinguishable from the tilt about the outer axis and
// is absorbed there, the middle encoder zero of a three-axis table is a rotation about the same
// axis as nonorthogonality middle_x and is absorbed there.
//
// Usage:
//   IndirectInput in{site, geometry, imu, table, segments};   // views, caller keeps the data
//   in.start = direct.coefficients.values.sensors;             // direct calibration (0)
//   CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
//   if (!r.ok) ... r.error;   r.coefficients -> interchange JSON with sigma/observable.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/calibration_result.h"
#include "calib/fit_quality.h"
#include "calib/model/motion.h"
#include "calib/recording_view.h"
#include "calib/segment_check.h"
#include "calib/sensor_model.h"
#include "calib/simulator.h"
#include "calib/static_detection.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

// One recording of the device on the table: IMU samples, encoder angles, segments (views; the
// caller keeps the data).
struct IndirectLeg {
  std::span<const nav::ImuSample> imu;  // t strictly increasing
  std::span<const TableSample> table;   // encoder angles (rad), t increasing
  std::span<const Segment> segments;    // static holds and rotate runs
};

// The recording (RecordingView: IMU t strictly increasing, static holds and rotate runs).
struct IndirectInput : RecordingView {
  // More recordings of the same device on the same table and mounting (e.g. the direct-plan
  // recording, whose static positions show axes the 12-run plan never points up): their holds
  // and runs join the same least-squares problem (same coefficients, same base tilt).
  std::vector<IndirectLeg> extra_legs;
  // Start values (the direct calibration, "0"); empty: nominal (scale 1, no errors).
  std::optional<SensorModel> start;
  // Their uncertainties by flat name (e.g. the direct result's CoefficientReport::uncertainty):
  // reported for the parameters this method holds at the start values.
  std::map<std::string, Uncertainty> start_uncertainty;
  Vec2 start_base_tilt = Vec2::Zero();
  Nonorthogonality start_nonorthogonality;
};

// Where the gyro misalignments come from (the frame every misalignment refers to).
enum class GyroReference {
  // The seed's decision: the gyro misalignments of the start values (the direct calibration,
  // measured against the orthogonal table axes) are kept and define the frame; the runs refine
  // the accelerometer misalignments relative to them. Needs IndirectInput::start.
  kStartValues,
  // Estimate the gyro misalignments from the runs as well (the plan must turn each axis from
  // two placements); used when there are no start values.
  kEstimate,
};

struct IndirectOptions {
  // Default: the seed's gyro-referenced convention (falls back to kEstimate, with a warning,
  // when the input has no start values).
  GyroReference gyro_reference = GyroReference::kStartValues;
  // Data at the edges of a hold is skipped: the table may still settle after a move.
  double static_margin_s = 1.0;
  // Holds shorter than this (after the margins) carry too little averaging to use.
  double min_static_s = 5.0;
  // The navigation through a run starts/ends this far inside the adjacent holds (capped at
  // half the hold), so the whole rotation including its ramps is integrated.
  double run_pad_s = 0.5;
  // Segments adjacent within this time count as "the hold before/after" a run.
  double adjacency_tolerance_s = 0.5;
  // A run next to a rest too short to be a hold (a settle segment after a move, before the
  // run starts) still starts or ends at the table's setting there: the encoder angles over at
  // most this much of the rest, the part next to the run, s. Such a rest gives no static
  // residual (too little averaging), only the run's start or end setting.
  double anchor_window_s = 0.5;
  // Outer iterations: re-navigate the runs at the new coefficients and re-solve; the problem
  // is nearly linear, so 2-3 suffice from a direct-calibration start.
  int max_outer_iterations = 5;
  // Stop when no parameter moved by more than this relative to its sigma.
  double outer_tolerance_sigma = 1e-3;
  // The inner solve of each outer iteration (Ceres, Levenberg-Marquardt on a small dense
  // problem: DENSE_QR, one thread so results are bit-identical from run to run and the daemon's
  // loop keeps the other core).
  struct SolverSettings {
    // The problem is nearly linear from a direct start: a handful of iterations converge; the
    // cap bounds a pathological recording (the outer loop re-solves anyway).
    int max_iterations = 50;
    // Tolerances far below the noise (the cost is a sum of squared normalised residuals):
    // the outer loop's test (outer_tolerance_sigma, 1e-3 sigma) must not be limited by an
    // inner solve that stopped early, as Ceres' defaults (1e-6 relative cost) could.
    double function_tolerance = 1e-15;
    double parameter_tolerance = 1e-15;
    double gradient_tolerance = 1e-20;
  };
  SolverSettings solver;
  // Floors of the per-sample noise estimated from the holds (noise-free simulations would
  // otherwise give zero weights' inverse): m/s^2 and rad/s.
  double min_accel_noise = 1e-6;
  double min_gyro_noise = 1e-9;
  // Floors of the sigmas of what the residuals compare (a hold's mean specific force, m/s^2,
  // and rate, rad/s; a run's navigated angle, rad): the resolution of the model itself (the
  // run navigation's discretisation is ~1e-7 rad at 100 Hz). Noise-free or finely quantised
  // recordings would otherwise weigh round-off and discretisation as signal; real noise is
  // far above them.
  double min_accel_mean_sigma = 2e-7;
  double min_gyro_mean_sigma = 2e-10;
  double min_run_angle_sigma = 2e-7;
  // Typical magnitudes of the parameters (a-priori ranges of a navigation-grade IMU and a
  // levelled table): the information matrix is scaled by them, so its eigenvalues compare a
  // combination's sigma with its range, in any units.
  double typical_scale = 1e-3;             // 1000 ppm
  double typical_misalignment = 1e-3;      // rad (~200 arcsec)
  double typical_accel_bias = 1e-3;        // m/s^2 (~100 ug)
  double typical_gyro_bias = 5e-7;         // rad/s (~0.1 deg/h)
  double typical_base_tilt = 1e-3;         // rad
  double typical_nonorthogonality = 1e-3;  // rad (certified tables: tens of arcsec)
  // A direction whose sigma exceeds this multiple of its typical magnitude is not observable
  // by the plan: its dominant parameter is fixed at the start value and flagged.
  double unobservable_sigma_typical = 1.0;
  // The solve is reported as badly conditioned when the scaled information's condition
  // number exceeds this (weak directions are named either way).
  double bad_condition_number = 1e10;
  // Hold a gyro scale at its start value (with the start's sigma, named in the warnings) when
  // the start determines it much better (sigma below a third) than the runs do: the direct
  // calibration measures gyro scales from encoder-timed rate runs, free of table errors, while
  // navigation sees no scale error of a turn about the vertical. Never a weaker source.
  bool prefer_start_gyro_scale = true;
  // Estimate the base tilt (false: hold it at start_base_tilt).
  bool estimate_base_tilt = true;
  // Estimate the axis nonorthogonality (two-axis: inner_y; three-axis: middle_x, middle_y,
  // inner_y); false: hold it at start_nonorthogonality (e.g. the table's certificate).
  bool estimate_nonorthogonality = true;
  // Refusals of bad recordings (every leg): gaps, non-finite values, samples at the IMU's range.
  IncrementCheckOptions checks;
  // How segments are merged (a hold split into settle + hold is one hold, so a run finds it)
  // and checked against the encoders (calib/segment_check.h).
  SegmentCheckOptions segment_check;
  // When the result is unusable (CalibrationResult::status, calib/fit_quality.h).
  FitQualityOptions quality;
  // The jackknife check of the sigmas (CalibrationResult::sigma_check): every hold and every
  // run left out once, each resample one Gauss-Newton step from the full solution (one
  // Jacobian and one small solve per resample: milliseconds); off by default here (the
  // calibration service decides).
  SigmaCheckOptions sigma_check;

  bool IsValid(std::string* why) const;
};

// Runs the calibration. The sigmas are the covariance's with each kind of residual (accel
// holds, gyro holds, runs) weighted by its noise times max(1, its normalised RMS): scaled by
// the measured residual. Result status kFailed with a message naming the cause when the input has
// no usable holds or runs, the solver fails (Summary::IsSolutionUsable() false) or the
// covariance cannot be computed.
CalibrationResult calibrateIndirect(const IndirectInput& input, const IndirectOptions& options);

// The calibrator's own Jacobian at the start values (whitened residuals of every hold and run
// w.r.t. the parameters of this table's chain, named "accel.scale.x", ..., in the order of
// calib/indirect/indirect_params.h): what its information analysis sees before the first solve.
struct IndirectJacobian {
  Status status = Status::Error("not computed");  // why not (bad options or input), when !ok
  std::vector<std::string> names;
  Eigen::MatrixXd jacobian;
};
IndirectJacobian indirectJacobian(const IndirectInput& input, const IndirectOptions& options);

// The navigation residual of one rotate run between two holds (the method's run residual,
// calib/indirect/indirect_run_cost.h): the attitude the navigation reaches at the end of the run
// against the table's end setting, about the two horizontal axes of L (rad), and its sigma from the
// gyro noise over the run.
struct RunAttitudeResidual {
  std::string label;
  double t0 = 0.0, t1 = 0.0;  // the run segment
  Vec2 tilt_rad = Vec2::Zero();
  double sigma_rad = 0.0;
};
// Every run's residual at the coefficients in.start (sensors), in.start_base_tilt and
// in.start_nonorthogonality: what the method's runs say of a coefficient set it did not
// estimate (explain's navigation residuals before and after its refit). An error when the
// recording has no usable hold; no runs: an empty list.
Result<std::vector<RunAttitudeResidual>> indirectRunResiduals(const IndirectInput& input,
                                                              const IndirectOptions& options);

// The truth of a simulated bench mapped into the gyro-referenced frame P of this method (what
// calibrateIndirect estimates): M_P = M_B * E^T with E = Rz(i0) exp([mu x]) (exact
// rotations), diagonal renormalised into the scale; base tilt += outer encoder zero about
// the outer axis (two-axis). Used by tests and the validation experiment.
struct GyroReferencedTruth {
  SensorModel sensors;
  Vec2 base_tilt = Vec2::Zero();
  Nonorthogonality nonorthogonality;  // three-axis middle_x includes the middle encoder zero
};
GyroReferencedTruth toGyroReferenced(const BenchTruth& truth, const TableGeometry& geometry);

}  // namespace imubench::calib
