// Model-discrepancy analysis ("imubench explain", issue 14): where the bench's forward model
// misses a recording, which physics it left out, how much of it, and how much better the fit
// is with it. Pure: values in, values out.
//
// Steps (docs/explain.md):
//   1. Windows and noise floor: the recording is cut into bins (calib/explain/explain_model.h); the
//      static holds give Allan deviations per channel (calib/explain/explain_noise.h), so a bin's
//      residual is weighed by the deviation of a mean over its own duration.
//   2. Residuals: measured mean readings minus the baseline model's prediction along the
//      recording's own encoder angles, per bin and channel, whitened.
//   3. Regressors: for the baseline coefficients and for every parameter of every candidate
//      effect (each id of the effect registry, calib/effects.h kAllEffects, plus the table's
//      geometric errors the baseline did not estimate), d(prediction)/d(parameter) by central
//      differences of the SAME forward model: nothing here restates physics.
//   4. Identifiability gate: candidate columns projected off the baseline's column space (SVD);
//      a parameter with nothing left is unseparable from the baseline (named with the baseline
//      coefficients it mimics), a parameter with no column at all is not excited; two
//      candidates whose projected column spaces share a direction (principal angle cosine
//      above ExplainOptions::unseparable_cos) are unseparable from each other. Unseparable
//      effects are reported with the motion that would separate them, never selected.
//   5. Selection: forward and backward steps by nested likelihood-ratio tests and BIC, the
//      noise floor as scale (inflated by the fullest model's chi^2 per degree of freedom when
//      that exceeds 1, so unmodelled structure does not make every candidate look significant,
//      and by the residual's long-run variance factor when it is correlated from bin to bin:
//      fewer independent bins than bins, ExplainOptions::correlation_window_s).
//      An accepted effect whose parameters would have to change along the recording (a
//      constancy test over consecutive parts) is withdrawn and the selection repeated: what it
//      fitted is structure outside the library.
//      When effects were accepted, selection is repeated once about the refitted baseline
//      (ExplainOptions::passes): a large effect biases the baseline calibration, and the
//      linearisation about it makes small candidates look significant.
//   6. Refit: Gauss-Newton on the baseline coefficients and the accepted effects jointly, with
//      sigmas from the inverse information times that scale.
//   7. Locate: windows (segments cut to ExplainOptions::window_s) whose mean residual exceeds
//      ExplainOptions::unexplained_sigma sigmas of the noise floor are reported before the
//      refit ("located") and after it ("unexplained": no library effect explains them).
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/explain/explain_fit.h"
#include "calib/explain/explain_model.h"
#include "calib/explain/explain_noise.h"
#include "calib/recording_view.h"
#include "calib/static_detection.h"

namespace imubench::calib {

// Channel names of the interchange report: accel.x .. gyro.z.
const char* explainChannelName(int channel);

// The recording (RecordingView; its static holds are used for the noise floor).
struct ExplainInput : RecordingView {
  // The baseline: coefficients the analysis starts from (a calibration of this recording or a
  // given file), how they were obtained ("direct" | "indirect" | "scalar" | "given") and which
  // table error coefficients (flat names, e.g. "table.base_tilt.x") the baseline estimates;
  // the other table errors are candidate effects.
  CoefficientReport baseline;
  std::string baseline_method = "given";
  std::vector<std::string> baseline_table_params;
  // The baseline was calibrated from this recording alone (method "direct" or "indirect"): a
  // recording whose motion cannot determine it is refused. False when other recordings took
  // part (the pipeline over a direct recording) or the coefficients were given.
  bool baseline_from_this_recording = true;
};

struct ExplainOptions {
  ExplainModelOptions model;
  NoiseFloorOptions noise;
  // Seconds dropped at both ends of a static hold for the noise floor: servo settling.
  double static_trim_s = 1.0;
  // Shortest static hold (after trimming) for the noise floor, s: shorter gives no Allan
  // point beyond a fraction of a second.
  double min_static_s = 4.0;
  // Candidate effect ids (interchange.md "Effect identifiers"); empty: the whole library.
  std::vector<std::string> candidates;
  // A candidate parameter whose column keeps less than this fraction of its norm after
  // projection off the baseline columns (correlation > 0.9995) is unseparable from them.
  double baseline_collinear = 0.03;
  // Two candidates are unseparable when their projected column spaces share a direction to
  // this cosine (0.995: 5.7 deg principal angle; the data cannot tell them apart at any
  // realistic signal-to-noise ratio).
  double unseparable_cos = 0.995;
  // Significance of an unexplained window, in noise-floor sigmas: with a few thousand
  // windows x channels, 5 sigma keeps chance detections below one in a hundred recordings.
  double unexplained_sigma = 5.0;
  // Constancy test of the accepted effects (a Chow test, calib/explain/explain.cpp leastConstant):
  // the recording is cut into this many consecutive parts of equal duration and an accepted effect
  // whose parameters fit significantly better with a value per part is withdrawn (its fit was of
  // structure outside the library: a step, a drift). Three parts see a change anywhere in the
  // recording, not only at its middle; 1 switches the test off.
  int consistency_parts = 3;
  // Significance of that change: 1e-4 keeps real (constant) effects withdrawn in fewer than
  // one recording in a thousand even with a few accepted effects, while structure an effect
  // only mimics changes the fit by far more.
  double consistency_p = 1e-4;
  // Effective-n correction of the tests (calib/explain/explain.cpp correlationFactor): the
  // residual's autocorrelation is summed over lags up to this time, s. 60 s covers the slow wander
  // (bias drift, thermal lag) that makes neighbouring bins dependent; 0 switches it off.
  double correlation_window_s = 60.0;
  // Only the factor's excess over this many of its white-noise standard errors is applied:
  // a white residual (every clean or fully explained recording) keeps its scale.
  double correlation_sigmas = 3.0;
  // angle_harmonic (an encoder's periodic angle error) is tried on every table axis that turns
  // at least harmonic_min_turn_rad, at orders 1..harmonic_max_order, and the candidate is the
  // variant that fits most of the residual (the selection then tests it like any other).
  // Order 1 is an eccentric encoder disc, 2 an elliptic one: the dominant terms. Each order
  // more is one more flexible variant to pick from; with 4, a 0.15 arcsec order-4 harmonic was
  // accepted on an independent recording with a 3 ms time delay (docs/explain.md).
  int harmonic_max_order = 2;
  double harmonic_min_turn_rad = 1.5;  // ~90 deg: a harmonic needs angles across the period
  // Longest window for locating residual structure, s (segments longer are cut).
  double window_s = 30.0;
  // The joint refit's Gauss-Newton (calib/explain/explain_fit.h: iterations at most, convergence in
  // sigmas); its termination is reported (ExplainResult::refit).
  RefitOptions refit;
  // Linearisations of the selection: a pass that accepts effects is repeated about the
  // refitted baseline coefficients (candidates at zero), up to this many passes. Two: the
  // second linearisation is about coefficients within their sigmas of the truth, where the
  // model is linear to far below the noise.
  int passes = 2;
  // Central-difference step of every regressor (SI units of the parameter): small against any
  // realistic parameter, large against the rounding of readings of order 10.
  double fd_step = 1e-6;
  // Threads that compute the regressors' columns (each with its own copy of the forward
  // model's cached table physics): the columns are most of the analysis' time and independent
  // of each other, and the bench PCs and CI have 2 cores. The results do not depend on it
  // (each column is computed the same way on whichever thread takes it). 1: no extra thread.
  int threads = 2;
  // Refusals: gaps, non-finite values, samples at the IMU's range.
  IncrementCheckOptions checks;
  // Given coefficients (baseline_method "given") that the recording moves by more than these
  // belong to another IMU (or another range setting) and are refused: far beyond the spread
  // of units of one type and beyond any drift between calibrations, far below the difference
  // between unrelated units or unit settings.
  double given_max_scale = 5e-3;         // 5000 ppm
  double given_max_misalignment = 5e-3;  // rad (~1000 arcsec)
  double given_max_accel_bias = 5e-2;    // m/s^2 (~5 mg)
  double given_max_gyro_bias = 5e-4;     // rad/s (~100 deg/h)

  bool IsValid(std::string* why) const;
};

struct ExplainAccepted {
  std::string effect;
  std::vector<std::string> flat_names;  // fitted parameters ("extra.lever_arm.r_m.x", ...)
  std::vector<double> values;
  std::vector<double> sigmas;
  double delta_bic = 0.0;  // BIC(without) - BIC(with): > 0 favours the effect
  double lr_stat = 0.0;    // likelihood-ratio statistic (chi^2 with k dof)
  double p_value = 1.0;
};

struct ExplainRejected {
  std::string effect;
  std::string reason;
  double delta_bic = 0.0;  // NaN when it was not tested (not excited)
};

struct ExplainUnseparable {
  std::vector<std::string> effects;
  std::string reason;
};

struct ExplainWindow {
  double t0 = 0.0, t1 = 0.0;
  int channel = 0;
  double sigma = 0.0;  // signed mean residual in noise-floor sigmas
  double mean = 0.0;   // mean residual, reading units
  std::string reason;
};

struct ExplainBinResidual {
  double t0 = 0.0, t1 = 0.0;
  int segment = -1;
  bool moving = false;
  std::array<double, 6> before{}, after{}, sigma{};  // reading units
};

// The navigation residual of one rotate run between two holds (the indirect method's run
// residual, calib/indirect/indirect_calibration.h indirectRunResiduals): the attitude the
// navigation reaches at the run's end against the table's, about the horizontal axes, rad.
struct ExplainRunResidual {
  std::string label;
  double t0 = 0.0, t1 = 0.0;
  std::array<double, 2> before{}, after{};
  double sigma = 0.0;  // from the gyro noise over the run
};

struct ExplainResult {
  Status status = Status::Error("not analysed");  // why not (bad input, too little data)
  // With a failed status: the input was readable but the recording cannot support the analysis
  // (its motion cannot determine the baseline, its static poses are too few or too short):
  // "result unusable", the same refusal `imubench calibrate` exits 3 for.
  bool unusable = false;
  std::string baseline_method;
  double baseline_normalised_rms = 0.0;  // whitened residual RMS of the baseline fit
  double after_normalised_rms = 0.0;
  // Per channel after the refit: sqrt(mean (residual / sigma)^2) over the bins, and the limit
  // above which the channel is above the noise floor (explainChannelLimit: chi-square based).
  std::array<double, 6> channel_normalised_rms{};
  std::array<double, 6> channel_limit{};
  NoiseFloor noise;
  // Residual RMS per channel over the bins (mean readings over ExplainModelOptions::bin_s),
  // reading units; noise_rms is what the noise floor alone gives over the same bins.
  std::array<double, 6> rms_before{}, rms_after{}, noise_rms{};
  double scale = 1.0;  // chi^2 per dof of the fullest model, at least 1 (test scale)
  // Of that scale, the effective-n factor: 1 for a white residual, > 1 when residual the
  // model leaves is correlated from bin to bin (fewer independent bins than bins).
  double correlation = 1.0;
  std::vector<ExplainAccepted> accepted;
  std::vector<ExplainRejected> rejected;
  std::vector<ExplainUnseparable> unseparable;
  std::vector<ExplainWindow> located;      // before the refit
  std::vector<ExplainWindow> unexplained;  // after it
  CoefficientReport coefficients;          // after the joint refit; accepted effects in extra
  // How the joint refit ended: steps, converged or stopped at the limit, the last step's
  // largest move in sigmas. Not converged: a note says the values may lie off the optimum.
  struct RefitTermination {
    int iterations = 0;
    bool converged = false;
    double last_step_sigma = 0.0;
    // chi^2 per degree of freedom of the refit: the sigmas are the design's (regressors and
    // noise floor) times sqrt(max(1, this)).
    double chi2_per_dof = 1.0;
  } refit;
  std::vector<ExplainBinResidual> bins;
  // Every rotate run between two holds, at the baseline and at the refitted sensor and table
  // coefficients (the extra effects are not in the navigation model); empty without such runs.
  std::vector<ExplainRunResidual> runs;
  std::vector<Segment> segments;
  std::vector<std::string> notes;
  // A joint analysis of several recordings (explainRecordings): recording k's clock plus
  // recording_offsets_s[k] is the analysis' time axis (bins, windows, segments and runs are on
  // it, one recording after the other). Empty for one recording.
  std::vector<double> recording_offsets_s;
};

// Which recording of a joint analysis time t (its time axis) lies in, and t on that
// recording's own clock. (0, t) for a single recording.
std::pair<int, double> explainRecordingTime(const ExplainResult& result, double t);

// Channels whose residual after the refit is above the noise floor (channel_normalised_rms >
// channel_limit), and the sentence the front ends print for the residual after the refit:
// "within the noise floor" only when no window is unexplained, every channel is within its
// limit and the floor was measured (not noise-free data).
std::vector<int> channelsAboveFloor(const ExplainResult& result);
std::string explainVerdict(const ExplainResult& result);
// The normalised RMS a channel of `bins` bins (fit taking `fitted` of its degrees of freedom)
// stays below by chance: the 99.9 % quantile of sqrt(chi^2_n / n), n = bins - fitted (Wilson-
// Hilferty), and at least 1.2 (the noise floor itself, from a few hundred Allan cluster pairs,
// is uncertain by several percent, and a residual 20 % above the noise is what matters).
double explainChannelLimit(double bins, double fitted);

// Why the recording's motion cannot determine a baseline calibration (calib/recording_checks.h
// motionSupport: distinct attitudes and rotations per body axis), or "" when it can. The
// analysis refuses such a recording (unusable) unless its baseline is given.
std::string explainMotionRefusal(const RecordingView& recording);

// A table recording (imubench-csv/1, or a stored run): bins along the encoder spline, the
// library forward model, the table groups the baseline did not estimate as candidates.
ExplainResult explainRecording(const ExplainInput& input, const ExplainOptions& options = {});

struct ExplainProblem;

// Several recordings of one IMU on one bench (issue 27 item 2: a recording and the follow-up
// that separates what it could not): one model over all of them, the bins of each recording
// whitened by its own noise floor, the baseline coefficients and every candidate shared (one
// IMU, one table: the same sensor errors and table errors in every recording; a turn-on bias
// that differs between power cycles shows as residual and as a constancy failure). The
// baseline (start values, its parameters, the candidate table groups) is inputs[0]'s; the
// others' `baseline` fields are ignored. Refused: fewer than two recordings, different table
// kinds or sites (another bench), a recording the single analysis refuses.
ExplainResult explainRecordings(std::span<const ExplainInput> inputs,
                                const ExplainOptions& options = {});

// One recording prepared for an analysis: checked (samples, table, static holds; a baseline
// from this recording needs motion that determines it), its noise floor, bins and per-row
// sigmas (noise and encoder interpolation; the model part alone in model_sigma).
struct ExplainPart {
  Status status = Status::Ok();
  bool unusable = false;  // ExplainResult::unusable
  NoiseFloor noise;
  ExplainData data;
  std::vector<double> sigma, model_sigma;
};
ExplainPart prepareExplainPart(const ExplainInput& input, const ExplainOptions& options);
// angle_harmonic's variants for a recording's axes (added to problem->candidates' variants,
// none twice), and the runs' navigation residuals at the baseline and at `after`.
void addHarmonicVariants(const ExplainData& data, const ExplainOptions& options,
                         ExplainProblem* problem);
std::vector<ExplainRunResidual> explainRunResiduals(const ExplainInput& input,
                                                    const BenchTruth& after);
std::string explainNavigationNote(const std::vector<ExplainRunResidual>& runs);

// ---- The analysis on prepared bins (table recordings above; table-free ones in
// calib/explain/explain_scalar.h) ----

struct ExplainCandidateSpec {
  std::string id;                  // interchange effect id
  std::vector<std::string> names;  // flat names of its fitted parameters (ExplainState names)
  // Discrete parameters held at a value while the others are fitted (angle_harmonic's axis
  // and order), flat name and value.
  using Fixed = std::vector<std::pair<std::string, double>>;
  Fixed fixed;
  // Alternative values of `fixed` (angle_harmonic on each turning axis at each order): the
  // first pass keeps the one that fits most of what the other candidates leave.
  std::vector<Fixed> variants;
  // Its parameters are one term together (angle_harmonic's cos and sin: a harmonic of unknown
  // phase): when the gate holds any of them, the candidate is not selected, since fitting the
  // rest would fix a phase the data did not choose (on the daemon's 20x recordings a sine
  // alone, its cosine absorbed by the baseline, came out at 780 arcsec).
  bool all_or_none = false;
};
// Every registry effect with fittable parameters (options.candidates filters).
std::vector<ExplainCandidateSpec> registryCandidates(const ExplainOptions& options);

struct ExplainProblem {
  const std::vector<ExplainBin>* bins = nullptr;  // measured mean readings per bin
  ExplainForward* forward = nullptr;              // their prediction for a state
  std::vector<double> sigma;                      // per row (bin-major, 6 per bin): noise and model
  std::vector<double> model_sigma;                // the model part alone (does not average down)
  NoiseFloor noise;
  ExplainState start;                       // the baseline
  std::vector<std::string> baseline_names;  // what the baseline fit varies
  std::vector<ExplainCandidateSpec> candidates;
  std::vector<Segment> segments;  // bins' segment indices refer here
  std::string baseline_method;
};
ExplainResult analyseProblem(const ExplainProblem& problem, const ExplainOptions& options);

// The pieces explainRecording builds its problem from, for analyses of other motions on the
// same model (calib/explain/explain_propose.h): per-row sigmas of prepared bins under a noise floor
// (noise and encoder interpolation), the baseline's flat names, the candidate effects (the
// table groups the baseline did not estimate, then the registry's).
std::vector<double> explainRowSigmas(const ExplainData& data, const NoiseFloor& noise);
std::vector<std::string> explainBaselineNames(const ExplainInput& input);
std::vector<ExplainCandidateSpec> explainCandidates(const ExplainInput& input,
                                                    const ExplainOptions& options);

// The interchange report (interchange.md "Explain report", imubench-explain/1).
nlohmann::json toJson(const ExplainResult& result);

}  // namespace imubench::calib
