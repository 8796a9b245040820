// Whether a calibration result can be used: the status every calibrator (direct, indirect,
// the bench pipeline) returns beside its payload, in the shape of Ceres'
// Summary::IsSolutionUsable() -- a code, a message, and the evidence (the largest residuals
// and where they are). A calibration that ran to completion can still be unusable: residuals
// far above the noise (the model does not fit the data: table errors, swapped columns,
// unmodelled effects), a coefficient the data cannot determine, or implausible values. The
// caller must check it; a confident wrong answer is the worst outcome of a calibration.
#pragma once

#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"

namespace imubench::calib {

enum class FitStatusCode {
  kUsable,    // the fit explains the data and determines every reported coefficient
  kFailed,    // no result: bad input, nothing to fit, solver failure (see message)
  kUnusable,  // a result exists but must not be used (see message and reasons)
};

// The one Status (base/status.h) with the calibrators' code and evidence: ok exactly when
// the code is kUsable; message is one line saying why not ("" when usable).
struct FitStatus : Status {
  FitStatusCode code = FitStatusCode::kUsable;
  std::vector<std::string> reasons;            // every finding, plain language
  std::vector<std::string> largest_residuals;  // "hold 'h3' (12.0-40.0 s) accel: 35 sigma"
  // The residuals exceed the noise (a finding says by how much): the model lacks something the
  // readings show, which `imubench explain` can name. False when the findings are only
  // coefficients the recording's motion does not determine or implausible values: there no
  // richer model helps, a recording that turns and points each axis (or the right columns) does.
  bool misfit = false;
  bool IsSolutionUsable() const { return code == FitStatusCode::kUsable; }
  // The calibrator ran and filled its payload (usable or not): every code but kFailed.
  bool HasResult() const { return code != FitStatusCode::kFailed; }
  // No result (kFailed): bad input, nothing to fit, solver failure.
  static FitStatus Failed(std::string why);
};

struct FitQualityOptions {
  // The normalised residual RMS (residual / its noise sigma) is ~1 when the model fits; a
  // value above this means model errors several times the noise: the coefficients have
  // absorbed them and are wrong by about as much.
  double max_normalised_rms = 3.0;
  // A scale factor further than this from 1 (SI recordings) is not a sensor error but a
  // wrong column, sign or unit.
  double max_scale_deviation = 0.05;
  // A misalignment above this (rad, ~3 deg) is a wrong column or axis, not an installation.
  double max_misalignment_rad = 0.05;
  // A scale factor or misalignment whose sigma exceeds this (1e-4: 100 ppm, 20 arcsec) is not
  // determined by the data: the plan does not turn or point that axis as it must. Raise it for
  // low-grade sensors whose noise alone is this large.
  double max_scale_sigma = 1e-4;
  double max_misalignment_sigma = 1e-4;

  bool IsValid(std::string* why) const;
  // This gate accepting a misfit up to max_rms: the sigma limits grow by the same ratio, since
  // the calibrators scale their sigmas by the normalised RMS (a pass whose misfit is known and
  // removed later, e.g. a thermal ramp's within-repetition drift, is not judged on it).
  FitQualityOptions acceptingMisfit(double max_rms) const;
};

// Findings on the coefficients of a report: a sensor coefficient the data do not determine
// (flagged unobservable, or without a sigma) and implausible values. Appends to reasons.
void judgeCoefficients(const CoefficientReport& report, const FitQualityOptions& options,
                       std::vector<std::string>* reasons);

// The status from the findings: kUsable when there are none, else kUnusable with a message
// naming the first finding, the largest residuals, and what to do next (`imubench explain`).
FitStatus fitStatusFrom(std::vector<std::string> reasons,
                        std::vector<std::string> largest_residuals);

}  // namespace imubench::calib
