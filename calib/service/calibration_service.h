// The one calibration policy of imubench: every front end (`imubench calibrate`, the daemon's
// end-of-plan calibration, explain's baseline) asks this service, so a recording gets the same
// method, start values, table errors and verdict wherever it is read. A thin application layer
// over the engine (calib/direct_calibration.h, calib/indirect/indirect_calibration.h,
// calib/indirect/bench_calibration.h); pure: value types in, value types out.
//
// The policy, in the order it is applied:
//   1. Method. Asked for (direct | navigation), or chosen from the motion (kAuto): a recording
//      with holds only gets the direct calibration; a recording with rotation runs gets the
//      direct calibration when that determines every coefficient with plausible values and is
//      usable, else the navigation-based calibration (which estimates the table errors).
//   2. Start values of the navigation-based calibration: given ones (CalibrationRequest::start),
//      else the direct calibration of the direct recording when it is plausible (scales within
//      ServiceOptions::max_start_scale_deviation of one, finite biases; the seed's
//      gyro-referenced convention keeps its gyro misalignments), else nominal values with the
//      gyro misalignments estimated from the runs.
//   3. Table errors. Known ones (the table's certification data) are given to every method and
//      held. Otherwise the navigation-based calibration estimates the base tilt and the axis
//      nonorthogonality (what its motion makes observable; weak directions are fixed and
//      flagged by the calibrator itself), and the direct calibration is repeated with a
//      significant nonorthogonality (second pass). Every table parameter of the table kind is
//      listed in CalibrationOutcome::table with whether it was estimated and, when held, why.
//   4. Gate. One status (calib/fit_quality.h): kFailed when no method gave a result, kUnusable
//      with the findings when the result must not be used. The direct calibration also needs
//      redundancy: with no more static positions than the unknowns of an axis the residual is
//      zero and its sigmas would claim a precision nobody measured.
//
// Usage:
//   CalibrationRequest rq;
//   rq.recording = view;                       // calib/recording_view.h
//   CalibrationOutcome c = calibrateRecording(rq, ServiceOptions{});
//   if (!c.status.HasResult()) ... c.status.message;
//   if (!c.status.IsSolutionUsable()) ... c.status.reasons;   // refuse: nothing written
//   c.coefficients -> interchange JSON
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/direct_calibration.h"
#include "calib/fit_quality.h"
#include "calib/indirect/bench_calibration.h"
#include "calib/indirect/indirect_calibration.h"
#include "calib/recording_view.h"
#include "calib/thermal/thermal_fit.h"

namespace imubench::calib {

enum class ServiceMethod {
  kAuto,        // what the motion supports (policy step 1)
  kDirect,      // the direct calibration alone
  kNavigation,  // the navigation-based calibration (the production pipeline)
};

const char* serviceMethodName(ServiceMethod m);

struct CalibrationRequest {
  // The recording to calibrate (the navigation runs when `direct` is given).
  RecordingView recording;
  // The direct plan's recording of the same device on the same table and mounting, when it is
  // a separate recording (the production pipeline); empty: `recording` is its own.
  std::optional<RecordingView> direct;
  ServiceMethod method = ServiceMethod::kAuto;
  // Start values of the navigation-based calibration (a coefficient file); empty: policy 2.
  std::optional<CoefficientReport> start;
  // The table's errors known beforehand (certification data): every method takes them, the
  // navigation-based calibration holds the nonorthogonality at them and starts the base tilt
  // there. Empty: none known (policy 3).
  std::optional<TableErrors> known_table_errors;
};

struct ServiceOptions {
  // The engine's options, with their own documented defaults. checks below replaces theirs.
  DirectCalibrationOptions direct;
  IndirectOptions indirect;
  // Refusals of bad recordings (gaps, non-finite values, samples at the IMU's range), for
  // every method.
  IncrementCheckOptions checks;
  // Second pass when a nonorthogonality component exceeds this many of its sigmas
  // (calib/indirect/bench_calibration.h).
  double nonorthogonality_significance_sigma = 2.0;
  // Passes of the pipeline at most, and when they stop (calib/indirect/bench_calibration.h).
  int max_passes = BenchCalibrationOptions{}.max_passes;
  double convergence_sigma = BenchCalibrationOptions{}.convergence_sigma;
  // A direct result may start the navigation-based calibration when every scale is within this
  // of one: further off, it is not a sensor error but a failed fit (wrong axis assignment,
  // unusable positions), and starting from it would steer the refinement wrong.
  double max_start_scale_deviation = 0.01;
  // Unknowns of the direct calibration per accelerometer axis (scale, bias, two
  // misalignments): no more static positions than this leave no redundancy.
  int direct_unknowns_per_axis = 4;
  // kAuto: when the first choice's result is unusable, try the navigation-based calibration
  // (which estimates the table errors the direct calibration takes as nominal) and keep it
  // when it is usable. explain's baseline turns this off: it analyses the plain model's misfit
  // and names the table errors itself.
  bool escalate_unusable = true;
  // The resampling check of the printed sigmas (calib/calibration_result.h, issue 26): the
  // navigation-based calibration's jackknife over its holds and runs, the direct
  // calibration's over its static positions and rate runs. Off by default: the daemon's
  // end-of-plan gate and explain's baseline do not print sigmas to a person; `imubench
  // calibrate` turns it on (its cost is one Jacobian and a small solve per resample: 0.06 s
  // on a 65-unit two-axis recording, 0.3 s on a 111-unit three-axis one, measured).
  SigmaCheckOptions sigma_check;

  bool IsValid(std::string* why) const;
};

// One table parameter of the table kind (flat name, calib/bench_truth.h) and what the
// calibration did with it.
struct TableParamDecision {
  std::string name;
  bool estimated = false;
  std::string reason;  // why held (and at what), or "estimated"
};

struct CalibrationOutcome {
  // The result's status (calib/fit_quality.h). kFailed: message says which step failed.
  FitStatus status = FitStatus::Failed("not calibrated");
  ServiceMethod method = ServiceMethod::kAuto;  // the method that gave the coefficients
  std::string why_method;                       // plain language: what the motion supports
  std::string start;  // navigation: "given", "direct calibration", "nominal"
  CoefficientReport coefficients;
  std::vector<TableParamDecision> table;  // every table parameter of the kind
  // The engine's results behind the coefficients, for reports: the direct calibration (the
  // one the coefficients or the refinement's start came from) and the refinement.
  std::optional<DirectCalibrationResult> direct;
  std::optional<DirectCalibrationResult> direct_first;  // navigation: the first pass' direct
  std::optional<CalibrationResult> refined;
  int passes = 0;                  // navigation: 1, or 2 after the nonorthogonality pass
  int holds = 0, runs = 0;         // what the segments of the recording hold
  std::vector<std::string> notes;  // plain language, in order
  // ServiceOptions::sigma_check on the method that gave the coefficients (their sigmas are
  // already raised when it is outside its band); why_not says why it was not done.
  SigmaCheck sigma_check;

  // Flat names of the table parameters that were estimated (and observable).
  std::vector<std::string> estimatedTableParams() const;
};

CalibrationOutcome calibrateRecording(const CalibrationRequest& request,
                                      const ServiceOptions& options = {});

// ---- Thermal: one IMU's coefficients over temperature -------------------------------------
//
// The same policy for a set of recordings of one IMU at several temperatures (a continuous
// ramp, soak points; `imubench thermal fit`):
//   1. Method: the joint fit of every static and rate run at its own temperature
//      (calib/thermal/thermal_fit.h fitThermalJoint, the default), or per-point direct calibrations
//      with polynomials through the points (fitThermalRuns, asked for).
//   2. Table errors: constant over temperature. Known ones (certification data) are held by
//      both methods. Otherwise the joint fit estimates every one the motion makes observable
//      and holds the rest at zero with the reason; the per-point method takes the table as
//      nominal (each point's direct calibration cannot separate it).
//   3. Gate: the method's status (calib/fit_quality.h): kUnusable with the findings when the
//      result must not be used (a triad's residual far above the noise floor, a coefficient
//      or an estimated table error not determined).

enum class ThermalMethod {
  kJoint,   // every row at its own temperature, table errors jointly (the default)
  kPoints,  // a direct calibration per temperature point, polynomials through the points
};

const char* thermalMethodName(ThermalMethod m);

struct ThermalCalibrationRequest {
  std::vector<ThermalRun> runs;  // one IMU (the caller checks the serials), one table kind
  ThermalMethod method = ThermalMethod::kJoint;
  // The table's errors known beforehand (certification data; zeros: a perfect table):
  // held by both methods. Empty: none known (policy 2).
  std::optional<TableErrors> known_table_errors;
};

struct ThermalServiceOptions {
  // Polynomial orders and reference temperature: both methods (this replaces theirs).
  ThermalFitOptions fit;
  // The joint fit's options with their documented defaults; its table policy (estimate_table,
  // direct.known_table_errors) is set from the request.
  ThermalJointFitOptions joint;
  // The per-point method's options (point span, refinement passes); its table is set from the
  // request.
  ThermalRunsFitOptions points;

  bool IsValid(std::string* why) const;
};

struct ThermalCalibrationOutcome {
  // kFailed (message names the run or point at fault), kUnusable with the findings, or usable.
  FitStatus status = FitStatus::Failed("not calibrated");
  ThermalMethod method = ThermalMethod::kJoint;
  ThermalRunsFitResult fit;               // the method's result (coefficients, points, table)
  std::vector<TableParamDecision> table;  // every table parameter of the kind
};

ThermalCalibrationOutcome calibrateThermal(const ThermalCalibrationRequest& request,
                                           const ThermalServiceOptions& options = {});

// The coefficients' frame: the navigation-based method refers every misalignment to the
// gyro-referenced platform frame (calib/indirect/indirect_calibration.h), the direct one to the
// body frame as written (its misalignments carry mounting and base tilt).
bool gyroReferenced(ServiceMethod method);

}  // namespace imubench::calib
