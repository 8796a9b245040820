// The thermal model fit: every coefficient of both triads (scales, biases, misalignments; the
// table's errors are temperature-independent: fitThermalJoint estimates them beside the
// polynomials, the per-point fit takes them as given) as a polynomial in
// T - t_ref of an order chosen per coefficient by BIC (0..4), plus a dT/dt term where
// heating and cooling differ (also by BIC), fitted jointly over all temperature points. The
// data are per-point calibrations with their sigmas: the direct calibration at each soak
// point (thermalPointsFromRun) or any other per-point estimate. The fitted form is
// calib/model/thermal_coefficients.h, the one the compensation (calib/thermal_model.h) and
// the simulator's truth evaluate.
//
// Per coefficient, over the points where it is observable, weighted least squares
//     value_i = sum_k c_k (T_i - t_ref)^k + h Tdot_i + e_i,   e_i ~ N(0, sigma_i^2)
// (columns scaled by the largest |T_i - t_ref| for conditioning). BIC = n ln(chi^2 / n) +
// p ln(n) (the points' sigmas known up to a common factor, so a calibration that states its
// sigmas uniformly too small or too large does not change the choice; with too few points
// for that, chi^2 + p ln(n) and exact interpolation allowed); the model with the
// smallest BIC wins among the models whose highest term (and dT/dt term) exceed
// min_term_sigma sigmas (order 0 always qualifies). Sigmas are the covariance's, scaled up by the
// reduced chi^2 when it exceeds 1 (the points scatter more than their own sigmas say).
// Point covariances between coefficients are not used (the direct calibration's are
// per-coefficient sigmas).
// fitThermalJoint (below) fits the same model from the direct calibration's raw rows instead of
// per-point calibrations, each row at its own temperature: what continuous ramps need and what
// `imubench thermal fit` uses by default.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/direct_calibration.h"
#include "calib/model/thermal_coefficients.h"
#include "calib/thermal_model.h"

namespace imubench::calib {

// One temperature point: a calibration made at (about) one IMU temperature.
struct ThermalFitPoint {
  std::string source;        // where it came from ("DIR segments T20C"), for messages
  double temp_c = 0.0;       // mean IMU temperature over the data used, degC
  double temp_rate = 0.0;    // mean IMU temperature rate over it, degC/s
  double temp_span_c = 0.0;  // max - min IMU temperature over it, degC
  // Parameter blocks (calib/model/sensor_equation.h offsets), their sigmas and observability.
  std::array<double, model::kTriadSize> accel{}, gyro{};
  std::array<double, model::kTriadSize> sigma_accel{}, sigma_gyro{};
  std::array<bool, model::kTriadSize> observable_accel{}, observable_gyro{};
};

struct ThermalFitOptions {
  // Polynomial order: -1 chooses per coefficient by BIC in 0..max_order; 0..4 fixes it (still
  // limited by the number of distinct temperatures).
  int order = -1;
  // Highest order BIC may choose: 4 (quartic) covers the curvature navigation-grade sensors
  // show over -40..+85 degC; more would chase noise with ~10 points.
  int max_order = model::kMaxThermalOrder;
  // Polynomial origin, degC: room temperature, where single-temperature calibrations are made,
  // so c0 is the room-temperature value.
  double t_ref_c = 20.0;
  // Points closer than this (degC) count as one temperature when the distinct temperatures
  // are counted (order limit, single-point refusal): soak repeatability is ~0.1 degC.
  double same_temperature_c = 0.5;
  // A dT/dt term is a candidate only when points were taken both heating and cooling at
  // |Tdot| above this (degC/s, 0.036 degC/h): a sensor soaked to rest drifts slower, and the
  // term would only fit noise.
  double min_hysteresis_rate = 1e-5;
  // Sigma floor relative to |value| (plus an absolute 1e-15): noise-free simulated points
  // report zero sigmas, which would make the weights infinite.
  double relative_sigma_floor = 1e-12;
  // A model is a candidate only if its highest polynomial term and its dT/dt term (when
  // present) exceed this many sigmas: BIC's ln(n) penalty alone admits a spurious extra order
  // for ~8 % of coefficients at n ~ 20 points (a 1.8-sigma gain), and there are 24
  // coefficients; a term below 3 sigma is no effect the data establish.
  double min_term_sigma = 3.0;

  bool IsValid(std::string* why) const;
};

// Fit diagnostics of one coefficient.
struct ThermalCoefficientFit {
  std::string name;   // flat name: "accel.bias.x", "gyro.misalignment.zy"
  int points = 0;     // points used (observable)
  double chi2 = 0.0;  // of the chosen model, with the points' own sigmas
  double bic = 0.0;
  double birge = 1.0;  // sqrt(reduced chi^2) applied to the sigmas (>= 1)
};

struct ThermalFitResult {
  // kFailed with why (single temperature point, unobservable coefficient, ...); kUsable once
  // fitted. Inside a ThermalRunsFitResult it is left as constructed (kUsable, empty) when a
  // run failed before the fit: check the outer status first.
  FitStatus status;
  model::ThermalCoefficients coefficients;
  std::vector<ThermalCoefficientFit> fits;  // accel then gyro, block order
  int distinct_temperatures = 0;
  bool hysteresis_candidate = false;  // points were taken heating and cooling
};

ThermalFitResult fitThermal(const std::vector<ThermalFitPoint>& points,
                            const ThermalFitOptions& options = {});

// Flat name of entry i (block order) of a triad ("accel" / "gyro").
std::string thermalCoefficientName(const std::string& triad, int index);

// ---- Points from one run ----------------------------------------------------------------

// A run is split into temperature points, each calibrated directly:
//   1. at its soak segments (the chamber moving to the next setpoint): soak-point plans;
//   2. between soaks, at a change of the repetition a segment label names: the label's part
//      before its last '/' ("ramp1/rep03/pos01_z_up" -> "ramp1/rep03"), so each repetition
//      of the calibration body in a continuous-ramp plan is one point;
//   3. a stretch without soaks or repetition labels whose IMU temperature spans more than
//      max_point_span_c (a continuous ramp recorded elsewhere, e.g. any imubench-csv/1 with a
//      temp column) into windows of consecutive segments spanning at most that.
// Each point carries its mean temperature and rate, so the dT/dt term is fitted from the
// heating and cooling legs. A run at one temperature without soaks is one point.
struct ThermalPointOptions {
  DirectCalibrationOptions direct;  // how each point is calibrated
  // Widest IMU temperature range (degC) of one window of rule 3: the coefficients' curvature
  // over a few degC stays far below the noise of one point, and narrower windows hold too
  // few static positions for a direct calibration.
  double max_point_span_c = 5.0;
  // A thermal model (the previous pass of fitThermalRuns) through which every sample of a
  // point is moved to the point's mean temperature and rate before its direct calibration
  // (true input at the sample's own (T, Tdot), reading again at the point's): a point that
  // spans degrees then calibrates as if soaked. Null: the samples as recorded.
  const model::ThermalCoefficients* reference = nullptr;

  bool IsValid(std::string* why) const;
};

struct ThermalPointsResult {
  // Why not: no temperatures, a point's calibration failed.
  Status status = Status::Error("no points made");
  std::vector<ThermalFitPoint> points;  // in time order
};

// source names the run in points and messages (e.g. the recording directory).
ThermalPointsResult thermalPointsFromRun(const DirectCalibrationInput& run,
                                         const std::string& source,
                                         const ThermalPointOptions& options = {});

// ---- The joint fit of whole runs ----------------------------------------------------------

// One recording and its name for messages.
struct ThermalRun {
  DirectCalibrationInput input;
  std::string source;
};

struct ThermalRunsFitOptions {
  ThermalFitOptions fit;
  ThermalPointOptions points;  // its reference is set by the passes
  // Passes after the first that re-make the points through the previous fit (reference):
  // the within-point drift of a continuous ramp (degrees over a repetition) biases a plain
  // direct calibration by far more than its noise; two passes take the bias below it (the
  // correction is linear in the model's error).
  int refinements = 2;
  // Normalised residual RMS accepted in every pass but the last: a point's drift shows as
  // model misfit until it is moved to one temperature (and inflates the sigmas, which are
  // scaled by the misfit: the sigma limits grow with it, FitQualityOptions::acceptingMisfit);
  // the last pass applies points.direct's gate.
  double max_normalised_rms_before_last = 1e6;

  bool IsValid(std::string* why) const;
};

struct ThermalRunsFitResult {
  // kFailed naming the run or point at fault, or the fit's own status (fit.status). The joint
  // fit: kUnusable (with the findings and the largest residuals) when the gate refuses it.
  FitStatus status = FitStatus::Failed("not fitted");
  ThermalFitResult fit;
  std::vector<ThermalFitPoint> points;  // of the last pass
  int passes = 0;
  // The joint fit's table errors: values.table (table_kind set) and, by flat name
  // ("table.base_tilt.x", ...), the sigma of each estimated error or observable false for each
  // held one. The per-point fit: the table as taken, every error held.
  CoefficientReport table;
  std::vector<std::string> notes;  // plain language: held table errors and why, skipped rows
  // Normalised residual RMS of each triad's rows (residual / standard error; ~1 at the noise
  // floor). Joint fit only (0 otherwise).
  double accel_normalised_rms = 0.0, gyro_normalised_rms = 0.0;
  int table_iterations = 0;  // outer iterations of the table errors (joint fit)
};

// Points of every run, fitted jointly; then `refinements` passes re-making the points
// through the previous fit. Soak points (spans of tenths of a degree) change by far less
// than their sigmas in the later passes; ramp repetitions are corrected for their drift.
ThermalRunsFitResult fitThermalRuns(const std::vector<ThermalRun>& runs,
                                    const ThermalRunsFitOptions& options = {});

// ---- The joint fit from the raw rows -----------------------------------------------------

// Every static position and rate run of every run is its own observation at its own mean IMU
// temperature and rate (the direct calibration's rows, calib/direct_calibration.h
// directObservations: mean reading, input, standard error of the mean), every coefficient
// c(T, Tdot) of calib/model/thermal_coefficients.h entering the sensor equation
// (calib/model/sensor_equation.h reading()):
//     mean reading_j = reading(block(T_j, Tdot_j), input_j) + e_j.
// Nothing is averaged over a temperature span, so a continuous ramp's rows are as sharp as a
// soak point's and no per-point calibration smears its coefficients over the degrees a
// repetition spans. Solved per triad by block Gauss-Seidel: each coefficient's polynomial and
// dT/dt term is fitted with the others held, linearised through the sensor equation's
// derivative (exact: eq. 1 is linear in each entry alone), choosing its order by BIC exactly as
// fitThermal does; sweeps repeat until no coefficient moves by more than `tolerance` of its
// sigma. Each entry enters one axis' reading, and a calibration plan's statics and rate runs
// nearly decouple the entries of one axis, so a few sweeps converge.
//
// The table's geometric errors (calib/table_model.h TableErrors: base tilt, nonorthogonality,
// mounting, encoder zeros) are constant over temperature. With estimate_table (default) every
// one the motion makes observable is an extra unknown: each row's input comes from the one
// chain (directObservations with DirectCalibrationOptions::known_table_errors at the current
// estimate, its derivative by a difference through the same chain), and a Gauss-Newton step
// over all polynomial terms and those table errors at once follows each Gauss-Seidel fit of
// the coefficients, until the table errors move by less than table_tolerance of their sigma.
// Observable: the errors' effect on the rows, with the coefficients' constant and linear terms
// and the table errors already taken projected out (base tilt, nonorthogonality, encoder
// zeros, mounting, in that order), keeps more than min_table_information of its norm and
// determines the error to max_table_sigma_rad. The others are held at
// direct.known_table_errors (zero by default) with the reason in notes and observable false:
// mounting and the inner encoder zero turn both triads together (their misalignments absorb
// them: the coefficients refer to the platform), the two-axis outer encoder zero is a tilt
// about the outer axis (in base_tilt), the three-axis middle zero is nu1_x's rotation (in
// nonorthogonality.middle_x), the three-axis outer zero is seen by the Earth rate alone.
// Without estimate_table the table is held at direct.known_table_errors (a certificate,
// `thermal fit --table-errors`).
//
// Sigmas: each coefficient's with the others held (Gauss-Seidel) or, when larger, its marginal
// sigma of the joint step with the table errors (scaled by the fit's Birge factor).
//
// The gate (calib/fit_quality.h, direct.quality): unusable when a triad's normalised residual
// RMS (row residual / its standard error, over every static and rate run) exceeds
// max_normalised_rms, a coefficient is not determined or implausible (judgeCoefficients on the
// values and sigmas at t_ref), or an estimated table error has a sigma above
// max_table_sigma_rad.
struct ThermalJointFitOptions {
  ThermalFitOptions fit;
  DirectCalibrationOptions direct;  // how the rows are built (trims, shortest rotation)
  TemperatureRateOptions rate;      // how Tdot is estimated from the recorded temperatures
  // Sweeps at most: the coupling between the entries of one axis is weak (a sweep takes the
  // error down by an order of magnitude), so more than this means the orders keep switching
  // and the last sweep's model is returned.
  int max_sweeps = 60;
  // Converged when no polynomial or dT/dt term moved by more than this many of its sigmas in
  // a sweep: far below the noise.
  double tolerance = 1e-3;
  // Estimate the observable table errors (see above); false: hold direct.known_table_errors.
  bool estimate_table = true;
  // Fraction of a table error's row signature that must remain once the coefficients' constant
  // and linear terms and the table errors already taken are projected out (below: the
  // coefficients or another table error absorb it).
  double min_table_information = 1e-4;
  // Largest sigma (rad, ~2 arcsec) of a table error estimated; above it the motion does not
  // determine it (held), or, after the fit, the result is unusable.
  double max_table_sigma_rad = 1e-5;
  // Outer iterations (rows rebuilt through the chain at the current table estimate) at most,
  // and the convergence test: every table error moved by less than this many of its sigmas.
  int max_table_iterations = 8;
  double table_tolerance = 1e-2;

  bool IsValid(std::string* why) const;
};

// The joint fit of the rows of every run. result.points stays empty (there are no per-point
// calibrations); result.passes is the number of sweeps.
ThermalRunsFitResult fitThermalJoint(const std::vector<ThermalRun>& runs,
                                     const ThermalJointFitOptions& options = {});

}  // namespace imubench::calib
