// Direct calibration on a two- or three-axis table (the seed's "calibration by direct
// measurements"): accelerometer scales, biases and six misalignments and the gyro biases from
// static positions; gyro scales and misalignments from rate runs (full turns / rotations).
//
// The table is taken as nominal (unless DirectCalibrationOptions::known_table_errors says
// otherwise): each static position's attitude C_LB comes from the encoder angles through the
// error-free chain, so table errors (base tilt, mounting, ...) leak into
// the coefficients exactly as the seed analyses. Per sensor axis i the model is linear:
//     mean reading_i = K_i . input + o_i,   K = diag(scale) M,  o = -diag(scale) bias
// with input = C_BL (0, 0, g) (accel, statics), C_BL w_ie_L (gyro, statics) and
// (axis_B * angle + integral of C_BL w_ie_L dt) / T (gyro, rotation of duration T: the axis
// of a single-axis rotation keeps its body coordinates). Least squares per axis; sigmas from
// the residual scatter; parameters the design cannot separate are named and flagged.
#pragma once

#include <string>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/calibration_result.h"
#include "calib/fit_quality.h"
#include "calib/model/motion.h"
#include "calib/recording_view.h"
#include "calib/segment_check.h"
#include "calib/simulator.h"
#include "calib/static_detection.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

// A recording-like value that owns its data (imubench-csv/1 in memory, SI); every function
// taking it also takes a RecordingView (calib/recording_view.h) of data the caller keeps.
struct DirectCalibrationInput {
  TableGeometry geometry;          // kind and (two-axis) outer-axis heading
  nav::Site site;                  // gravity and Earth-rate projection
  nav::ImuSamples imu;             // increments, t = END of each interval
  std::vector<TableSample> table;  // encoder readings, rad, any rate
  std::vector<Segment> segments;   // kStatic and kRotate are used, others ignored
};

enum class DirectEstimator {
  // The seed's classic direct calibration: per axis, scale and bias from the positions with
  // that axis up and down (gyro: bias from those statics, scale from the rate runs), the
  // misalignments by least squares with them held. Table errors tilt the input of a vertical
  // axis only to second order, so scales and biases stay free of them.
  kAxisPairs,
  // One least-squares fit of all four unknowns per axis over every position: uses the data
  // best, but lets table errors leak into scales and biases on unbalanced plans.
  kJointLeastSquares,
};

struct DirectCalibrationOptions {
  // Which estimator (see DirectEstimator); the seed's is the default.
  DirectEstimator estimator = DirectEstimator::kAxisPairs;
  // Seconds left out at both ends of a static segment: servo settling after a move.
  double static_trim_s = 0.5;
  // Shortest static segment used (after trimming), s: shorter means average too little.
  double min_static_s = 1.0;
  // Shortest rotation used, rad: a rate run must turn enough for the angle to dominate
  // encoder and timing errors (the seed uses full turns and 180-degree reversals).
  double min_rotation_rad = kPi / 2.0;
  // Tolerance on the turn of a run when it is compared with min_rotation_rad, rad (~0.2
  // arcsec): encoders and other programs' number formatting end a quarter turn at 89.99999985
  // deg, which is a quarter turn.
  double turn_tolerance_rad = 1e-6;
  // How segments are merged (a hold split into settle + hold is one hold) and checked against
  // the encoders (calib/segment_check.h).
  SegmentCheckOptions segment_check;
  // When the result is unusable (calib/fit_quality.h): residuals far above the noise, an
  // undetermined coefficient, implausible values.
  FitQualityOptions quality;
  // Smallest noise sigma of a row's mean when residuals are normalised (m/s^2, rad/s): below
  // it a residual is numerical round-off (noise-free or finely quantised data).
  double accel_residual_floor = 1e-6;
  double gyro_residual_floor = 1e-9;
  // Include the Earth-rate projection in the gyro model (off only for Earth-rate-blind
  // sensors whose bias would otherwise absorb it pose by pose).
  bool use_earth_rate = true;
  // Table errors known beforehand (a certificate, or the navigation-based refinement's
  // estimate of base tilt and nonorthogonality, calib/indirect/bench_calibration.h): the chain uses
  // them instead of the nominal table. Default: none (the seed's direct calibration).
  TableErrors known_table_errors;
  // Refusals of bad recordings: gaps, non-finite values, samples at the IMU's range.
  IncrementCheckOptions checks;

  bool IsValid(std::string* why) const;
};

struct DirectCalibrationResult {
  // kFailed (message: why; bad input, nothing to fit) until the fit ran and filled the payload
  // (status.HasResult()). Whether the coefficients can be used (status.IsSolutionUsable()):
  // the table taken as nominal while it has errors, swapped columns or a plan that leaves a
  // coefficient undetermined give status kUnusable with the reasons and the largest residuals.
  FitStatus status = FitStatus::Failed("not calibrated");
  double normalised_residual_rms = 0.0;  // static and rotation rows, residual / noise sigma
  // The same per triad (goodness of fit): accelerometer rows, gyro rows (statics and runs).
  double accel_normalised_rms = 0.0;
  double gyro_normalised_rms = 0.0;
  // The sigmas are scaled by the measured residual: the axis-pairs estimator propagates the
  // sensor noise alone, so its misalignment sigmas are multiplied by max(1, the triad's
  // normalised RMS); its scales and biases cancel a tilted input to first order and keep the
  // noise's (the joint least squares' covariance already carries the residual scatter). 1: the
  // noise model fits.
  double accel_sigma_factor = 1.0;
  double gyro_sigma_factor = 1.0;
  // Accel and gyro coefficients (report.values.sensors), sigmas and unobservable flags by
  // flat name; report.values.table stays zero (direct calibration does not estimate it).
  CoefficientReport report;
  int statics_used = 0;
  int rotations_used = 0;
  double accel_residual_rms = 0.0;  // m/s^2, static means minus fitted model
  double gyro_residual_rms = 0.0;   // rad/s, static and rotation rows
  std::vector<std::string> notes;   // plain-language: skipped segments, weak parameters
};

DirectCalibrationResult calibrateDirect(const RecordingView& input,
                                        const DirectCalibrationOptions& options = {});
DirectCalibrationResult calibrateDirect(const DirectCalibrationInput& input,
                                        const DirectCalibrationOptions& options = {});

// The jackknife check of a direct calibration's sigmas (calib/calibration_result.h): every
// static position (its accelerometer and gyro rows) and every rate run left out once, the
// triads refitted (linear: no start needed), the leave-one-out scatter against the sigmas of
// `full` (calibrateDirect(input, options)). Not done (why_not) with fewer positions and runs
// than options.min_resamples.
SigmaCheck jackknifeDirect(const RecordingView& input, const DirectCalibrationOptions& options,
                           const DirectCalibrationResult& full, const SigmaCheckOptions& check);

// One row of the linear model above as calibrateDirect builds it: the mean reading of a static
// position (an accelerometer and a gyro row) or of a rate run (a gyro row), the input it was
// taken at and the standard error of the mean. For estimators that fit the rows otherwise
// (the joint thermal fit, calib/thermal/thermal_fit.h: each row at its own temperature).
struct DirectObservation {
  bool accel = false;     // accelerometer row (static); else gyro (static or rate run)
  bool rotation = false;  // rate run
  Vec3 input = Vec3::Zero(), reading = Vec3::Zero(), reading_se = Vec3::Zero();
  double t0 = 0.0, t1 = 0.0;  // the segment's span, s
  std::string label;
};

struct DirectObservations {
  Status status = Status::Error("no observations collected");  // why not: bad input, < 4 statics
  std::vector<DirectObservation> rows;
  std::vector<std::string> notes;  // skipped segments
};

DirectObservations directObservations(const RecordingView& input,
                                      const DirectCalibrationOptions& options = {});
DirectObservations directObservations(const DirectCalibrationInput& input,
                                      const DirectCalibrationOptions& options = {});

}  // namespace imubench::calib
