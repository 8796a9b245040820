// The missing-physics analysis of a completed run as the daemon runs it (issue 14 item 9,
// issue 15 item 2): calib's explain (calib/explain/explain.h) on the run's recording, starting from
// the run's final calibration — the coefficients the plan's method estimated, and the table errors
// it estimated — so the report says what that calibration left in the residuals. Runs on a
// worker thread with the final calibration (daemon/online_engine.h finalCalibration). Pure:
// value types in, value types out.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/explain/explain.h"
#include "daemon/follow_up.h"
#include "daemon/run_calibration.h"
#include "io/recording.h"
#include "plans/plan.h"

namespace imubench::daemon {

struct RunExplain {
  // Not ok: why no report (the run itself is not affected).
  Status status = Status::Error("not analysed");
  nlohmann::json report;  // imubench-explain/1 (interchange.md "Explain report"), when ok
  // One line for the log and the `results` event: the accepted effects, the whitened residual
  // RMS before and after (1 = the noise floor), the windows nothing explains.
  std::string summary;
  // The follow-up proposal (daemon/follow_up.h "follow_up" result), when asked for and the
  // analysis found unseparable groups.
  std::optional<nlohmann::json> follow_up;
};

// The analysis of rec from c (the final calibration of rec with `method`): its baseline is
// c's coefficients, with the method and the table parameters the calibration service
// estimated (RunCalibration::baseline_method, table_params). !c.ok: no analysis (nothing to
// start from), the error says why. follow_up (not null): the proposal is designed too.
RunExplain explainRun(plans::CalibrationMethod method, const io::Recording& rec,
                      const RunCalibration& c, const calib::ExplainOptions& options = {},
                      const FollowUpSetup* follow_up = nullptr);

}  // namespace imubench::daemon
