// The calibration of a bench run as the daemon runs it: the plan's method
// (plans::CalibrationMethod) over the run's recording (and, for the pipeline, the recording of
// the direct plan's run), through the one calibration service (calib/service/calibration_service.h)
// the CLI and explain's baseline call too; then the pass/fail verdict against
// the bench file's acceptance limits. Used for the online estimates during a run (on a part of
// the recording) and for the full calibration at its end. Pure apart from nothing: value
// types in, value types out (it runs on a worker thread).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"
#include "calib/fit_quality.h"
#include "daemon/bench_file.h"
#include "io/recording.h"
#include "plans/plan.h"

namespace imubench::daemon {

struct RunCalibration {
  // Not ok: why not (too little data so far, a refused recording, ...). ok: coefficients were
  // computed; whether they can be used is `fit` (the online estimates show partial ones).
  Status status = Status::Error("not calibrated");
  // The calibration service's gate (calib/fit_quality.h), reported with the estimate and the
  // verdict ("usable", "findings").
  calib::FitStatus fit = calib::FitStatus::Failed("not calibrated");
  calib::CoefficientReport coefficients;  // valid when status.ok
  // The table parameters the method estimated (flat names) and the baseline method name of
  // the missing-physics analysis ("direct" | "indirect"), as the service decided them.
  std::vector<std::string> table_params;
  std::string baseline_method;
  // The flat names the method could not determine from these data ("observable": false in
  // the coefficients, or every parameter when not ok).
  std::vector<std::string> unobservable;
  nlohmann::json report;  // method, the calibrator's diagnostics (residuals, conditioning, notes)
};

// Calibrates rec with `method` (not kNone). direct: the pipeline's direct-plan recording
// (required for kPipeline, ignored otherwise). known_table_errors: the bench file's [table]
// errors (certification data), taken as known by every method; nullopt: unknown.
RunCalibration calibrateRun(plans::CalibrationMethod method, const io::Recording& rec,
                            const io::Recording* direct,
                            const std::optional<calib::TableErrors>& known_table_errors);

// The estimate as JSON for the `estimate` event and the report: per estimated parameter its
// value and sigma in display units (ppm for scale - 1, ug, deg/h, arcsec), and the list of
// parameters still unobservable.
nlohmann::json estimateJson(const RunCalibration& c);

// Pass/fail of the coefficients against the limits: {"pass": bool|null, "rows": [{parameter,
// value, sigma, limit, unit, pass, why}]}. A limited parameter the calibration did not
// determine fails ("not determined"): the verdict never passes what was not measured.
// "usable" says whether the fit itself passed the calibration service's gate (residuals at the
// noise), with its "findings" when not. An unusable fit gets no verdict ("pass": null, "why"
// says so; the rows still show each value against its limit): its values carry what the model
// left out and its sigmas understate the error, the reason `imubench calibrate` refuses the same
// fit. No limits: "pass": null (no verdict).
nlohmann::json acceptanceVerdict(const RunCalibration& c,
                                 const std::vector<AcceptanceLimit>& limits);

// Mean temperature of a run for its results: the chamber's measured temperature, else the
// IMU's reported one; nullopt when neither was recorded.
std::optional<double> runTemperature(const io::Recording& rec);

}  // namespace imubench::daemon
