// What a calibrator returns besides the coefficients: solver status, conditioning of the
// information matrix in NAMED parameters, residual summary. Shared by the calibration methods
// (direct, indirect): the coefficients themselves are a calib::CoefficientReport
// (calib/bench_truth.h: values, sigmas, "observable": false flags -> interchange JSON).
#pragma once

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
  std::vector<std::string> warnings;  // skipped runs/holds and why
};

nlohmann::json toJson(const Conditioning& c);

}  // namespace imubench::calib
