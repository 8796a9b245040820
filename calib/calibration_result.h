// What a calibrator returns besides the coefficients: solver status, conditioning of the
// information matrix in NAMED parameters, residual summary. Shared by the calibration methods
// (direct, indirect): the coefficients themselves are a calib::CoefficientReport
// (calib/bench_truth.h: values, sigmas, "observable": false flags -> interchange JSON).
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/fit_quality.h"

namespace imubench::calib {

// One weak (or null) direction of the information matrix: a unit combination of parameters
// the data barely constrains, e.g. "0.71 accel.misalignment.zy - 0.71 table.base_tilt.x".
struct WeakDirection {
  double relative_eigenvalue = 0.0;  // eigenvalue / largest, of the scaled information
  // 1-sigma of this combination in units of the parameters' typical magnitudes (the scaling
  // of the information matrix): > 1 means the data constrain it less than its a-priori range.
  double sigma_typical = 0.0;
  std::vector<std::pair<std::string, double>> components;  // |component| >= 0.1, largest first
  std::string describe() const;
};

struct Conditioning {
  double condition_number = 0.0;    // largest / smallest eigenvalue over the estimated params
  bool bad = false;                 // condition_number above the method's threshold
  std::vector<WeakDirection> weak;  // the weakest directions (also the null ones fixed)
  std::vector<std::string> fixed_unobservable;  // parameters fixed because the plan can't see them
  std::string describe() const;  // one line per weak direction, naming the parameters
};

// A resampling check of the printed sigmas (issue 26): the coefficients re-estimated on
// resampled data (leave one hold or run out: jackknife; or each half of the recording on its
// own), their scatter turned into a sigma of the full estimate and compared with the printed
// one. ratio ~1: the printed sigmas are honest; >> 1: they claim a precision the data do not
// have (unmodelled effects, noise that is not white); << 1: they are conservative.
struct SigmaGroupRatio {
  std::string group;    // "accel.scale", "gyro.misalignment", "table.base_tilt", ...
  double median = 0.0;  // median over the group's parameters of resampled / printed sigma
  int parameters = 0;
};

struct SigmaCheckOptions {
  // Run the check (one resample per hold, run or half: see the front end's comment on its
  // cost). Off in the engine by default; the calibration service's caller turns it on.
  bool enabled = false;
  // The band of honest ratios: a median ratio outside it is said, and the printed sigmas
  // become the larger of printed and resampled. Jackknife estimates of a sigma from 10-40
  // resamples scatter by 10-25 %; [0.7, 1.5] leaves room for that and the jackknife's
  // known upward bias at high-leverage holds, and catches a factor 2.
  double min_ratio = 0.7;
  double max_ratio = 1.5;
  // Fewest resamples (holds + runs left out one at a time) for a jackknife: fewer give a
  // sigma estimate scattering by more than ~35 %, no check at all.
  int min_resamples = 8;

  bool IsValid(std::string* why) const;
};

struct SigmaCheck {
  bool done = false;
  std::string method;   // "jackknife over 33 holds and 32 runs", "half against half"
  std::string why_not;  // when !done: what the recording lacks
  int resamples = 0;
  std::vector<SigmaGroupRatio> groups;
  double median_ratio = 0.0;  // over every compared parameter
  // median_ratio outside [min_ratio, max_ratio] (a group of one or two parameters scatters too
  // much to judge alone: the groups are listed, the median over all is judged).
  bool outside = false;
  double min_ratio = 0.0, max_ratio = 0.0;  // the band (SigmaCheckOptions)
  // The resampled sigma of each compared parameter (flat name), and whether the report's
  // sigmas were raised to it (outside: the larger of the two).
  std::map<std::string, double> resampled_sigma;
  bool sigmas_raised = false;
  std::string describe() const;  // one line (or two when outside), ending in '\n'
};

// The check from printed and resampled sigmas by flat name (parameters in both with printed >
// 0 compared, grouped by the name up to its last '.'); done when any was compared.
SigmaCheck compareSigmas(const std::map<std::string, double>& printed,
                         const std::map<std::string, double>& resampled,
                         const SigmaCheckOptions& options);
// When the check is outside its band: every compared sigma of the report becomes the larger
// of printed and resampled (check->sigmas_raised).
void raiseSigmas(CoefficientReport* report, SigmaCheck* check);
// The jackknife sigma of each parameter from its n leave-one-out estimates:
// sqrt((n-1)/n * sum (x_i - mean)^2).
std::map<std::string, double> jackknifeSigmas(
    const std::vector<std::map<std::string, double>>& estimates);

nlohmann::json toJson(const SigmaCheck& c);

struct CalibrationResult {
  // kFailed (message names the cause: bad input, solver failure) until the calibration ran
  // (status.HasResult()). Whether the coefficients can be used (calib/fit_quality.h):
  // residuals far above the noise or a coefficient the data do not determine make it
  // kUnusable even then.
  FitStatus status = FitStatus::Failed("not calibrated");
  CoefficientReport coefficients;
  Conditioning conditioning;
  std::string solver_report;  // Ceres BriefReport of the final solve
  int outer_iterations = 0;
  double rms_normalised_residual = 0.0;  // ~1 when the noise model fits the data
  // The same per kind of residual (goodness of fit per triad): accelerometer holds, gyro holds,
  // the runs' navigated end attitudes (gyro); 0 where the recording has none.
  double accel_normalised_rms = 0.0;
  double gyro_normalised_rms = 0.0;
  double run_normalised_rms = 0.0;
  // The sigmas are scaled by the measured residual: each kind of residual is weighted with
  // its noise times max(1, its normalised RMS) in the covariance, so an under-modelled
  // recording does not print the precision of its noise alone. 1: the noise model fits.
  double accel_sigma_factor = 1.0;
  double gyro_sigma_factor = 1.0;
  double run_sigma_factor = 1.0;
  SigmaCheck sigma_check;  // IndirectOptions::sigma_check: leave-one-out over holds and runs
  std::vector<std::string> warnings;  // skipped runs/holds and why
};

nlohmann::json toJson(const Conditioning& c);

}  // namespace imubench::calib
