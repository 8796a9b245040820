#include "daemon/run_explain.h"

#include <cstdio>
#include <exception>

#include "io/sim_recording.h"

namespace imubench::daemon {
namespace {

std::string summaryOf(const calib::ExplainResult& r) {
  std::string effects;
  for (const calib::ExplainAccepted& a : r.accepted) {
    effects += (effects.empty() ? "" : ", ") + a.effect;
  }
  char rms[160];
  std::snprintf(rms, sizeof(rms),
                "normalised residual RMS %.3g -> %.3g (1 = noise floor), %zu unexplained "
                "window(s)",
                r.baseline_normalised_rms, r.after_normalised_rms, r.unexplained.size());
  return "explain (" + r.baseline_method + " baseline): " +
         (effects.empty() ? std::string("no effect accepted") : "accepted " + effects) + "; " + rms;
}

}  // namespace

RunExplain explainRun(plans::CalibrationMethod method, const io::Recording& rec,
                      const RunCalibration& c, const calib::ExplainOptions& options,
                      const FollowUpSetup* follow_up) {
  RunExplain out;
  if (!c.status.ok) {
    out.status = Status::Error("no final calibration to start from (" + c.status.message + ")");
    return out;
  }
  const io::CalibrationView view(rec);
  calib::ExplainInput in;
  in.recording() = view.view();
  in.baseline = c.coefficients;
  in.baseline_method = c.baseline_method;
  in.baseline_table_params = c.table_params;
  calib::ExplainResult r;
  try {
    r = calib::explainRecording(in, options);
  } catch (const std::exception& e) {
    // The analysis never fails the run: whatever it throws (allocation) is its error.
    out.status = Status::Error(std::string("the analysis failed: ") + e.what());
    return out;
  }
  if (!r.status.ok) {
    out.status = r.status;
    return out;
  }
  if (method == plans::CalibrationMethod::kPipeline) {
    r.notes.push_back(
        "baseline: the run's pipeline calibration (direct plan run, then the navigation-based "
        "refinement over this run)");
  }
  out.status = Status::Ok();
  if (follow_up != nullptr) out.follow_up = proposeFollowUp(in, r, options, *follow_up);
  out.report = calib::toJson(r);
  out.summary = summaryOf(r);
  return out;
}

}  // namespace imubench::daemon
