// The follow-up experiment in the daemon (issue 27 item 3): when a run's end-of-plan analysis
// (daemon/run_explain.h) reports groups its recording cannot separate, the plan that separates
// them is designed (calib/explain/explain_propose.h, within the bench's [table] limits) and stored
// with the run's results as a "follow_up" result; the bench file's [explain] follow_up policy says
// whether it is also queued. When the follow-up run completes, one model over both runs
// (calib::explainRecordings) says per group whether it is resolved, stored with the follow-up's
// results as a "follow_up_joint" result. proposeFollowUp and jointFollowUp are pure (value types
// in, value types out); judgeFollowUp reads the store on its own connection. The daemon runs
// them on its worker and stores the JSON on its loop.
//
// "follow_up" result (JSON, format "imubench-follow-up/1"):
//   run, method, direct_run (the origin's calibration, so the joint analysis starts from it),
//   status: "proposed" (plan below) | "refused" (no plan within the bench limits separates a
//   group: reason, nothing queued), limits {max_rate_deg_s, max_accel_deg_s2, max_duration_s},
//   plan {name, toml, duration_s, blocks: [purpose]} when proposed, groups: [{effects,
//   unseparable, resolved, possible, why, angle_before_deg, angle_after_deg, limit_deg,
//   parameters: [{name, sigma_before, sigma_after, sigma_joint}]}] (sigmas SI, null: held),
//   notes.
// "follow_up_joint" result (format "imubench-follow-up-joint/1"): origin_run, run, ok, error,
//   groups: [{effects, verdict: "resolved" | "still unseparable", parameters: [{name, value,
//   sigma, sigma_predicted}]}], summary, report (imubench-explain/1 of the joint analysis).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "calib/explain/explain.h"
#include "calib/explain/explain_propose.h"
#include "daemon/run_calibration.h"
#include "io/recording.h"
#include "plans/plan.h"

namespace imubench::daemon {

inline constexpr const char* kFollowUpKind = "follow_up";
inline constexpr const char* kFollowUpJointKind = "follow_up_joint";

// What the design needs besides the analysis.
struct FollowUpSetup {
  std::int64_t run_id = 0;  // the origin run
  plans::CalibrationMethod method = plans::CalibrationMethod::kNone;
  std::optional<std::int64_t> direct_run;  // kPipeline: the direct plan's run
  // The bench's [table] max_rate / max_accel (never looser than the device's) and the search's
  // defaults (calib/explain/explain_propose.h).
  calib::ProposeOptions propose;
};

// The proposal for `result` (the analysis of `input`, with `explain_options`); nullopt when the
// analysis found no unseparable group (nothing to follow up). It holds a plan only when the plan
// separates at least one unseparable group; a group the design sees separable on the recording
// already (its angle before above the limit, against explain's verdict) is not claimed.
std::optional<nlohmann::json> proposeFollowUp(const calib::ExplainInput& input,
                                              const calib::ExplainResult& result,
                                              const calib::ExplainOptions& explain_options,
                                              const FollowUpSetup& setup);

// The plan name of run N's follow-up ("follow_up_of_run_N").
std::string followUpPlanName(std::int64_t run_id);

// One line for the log and the event: "proposed: <plan> (<s> s) for <groups>" or "refused: ...".
std::string followUpSummary(const nlohmann::json& follow_up);

// The joint analysis of the origin run (origin: its recording with its final calibration as
// the baseline) and the follow-up run, judged against the origin's stored proposal (its
// unseparable groups): resolved (the effects' values, achieved and predicted sigmas) or still
// unseparable.
nlohmann::json jointFollowUp(const nlohmann::json& proposal, const calib::ExplainInput& origin,
                             const calib::ExplainInput& follow_up, std::int64_t follow_up_run,
                             const calib::ExplainOptions& options = {});

// After run_id completed: when its plan is a stored proposal of this IMU (the newest
// "follow_up" result whose plan text is the run's), the origin run is calibrated again as its
// results were (method, direct run) and jointFollowUp judges both; nullopt: run_id is no
// follow-up. A failure (the store, a run gone) is a result with ok false and the error.
// (clang-tidy sees nlohmann::json's assertion-checked special members as throwing; they do not
// throw for a valid json, and a struct of three members has nothing to catch.)
struct FollowUpJudged {  // NOLINT(bugprone-exception-escape)
  std::string imu_serial;
  double temperature_c = 0.0;
  nlohmann::json joint;
};
// known_table_errors: the bench file's [table] errors (calibrateRun).
std::optional<FollowUpJudged> judgeFollowUp(
    const std::string& db_path, std::int64_t run_id,
    const std::optional<calib::TableErrors>& known_table_errors,
    const calib::ExplainOptions& options = {});

}  // namespace imubench::daemon
