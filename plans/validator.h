// Plan validation: rejects a bad plan before anything moves, every error with
// file:line:column and the reason, ALL errors collected (not just the first).
//
// Checked here (the parser already refused bad TOML, missing units, wrong unit dimensions,
// unknown keys and unknown step types): unknown axes for the table kind, rates and
// accelerations above the table limits (or non-positive), targets outside a limited axis's
// range, 180-degree position moves (ambiguous: use rotate with a direction), non-positive
// durations, repeat count < 1, chamber setpoints outside the chamber range, ramp rates above
// its limit, chamber steps without a [chamber] section, and a plan that never records.
//
// checkPlan() is the CLI-facing front end of `imubench plan check PLAN`.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "io/toml_diagnostics.h"
#include "plans/plan.h"

namespace imubench::plans {

struct ValidatorOptions {
  // A position move within this of 180 degrees is refused: encoder noise could send the
  // table either way round.
  double ambiguous_move_tolerance = 1.0 * 3.141592653589793 / 180.0;  // rad
  // Unrolled repeats beyond this many steps are refused: a typo'd count must not make the
  // checker (or the bench) run for days.
  long max_unrolled_steps = 1000000;
  // A plan that never records produces nothing to calibrate with.
  bool require_recording = true;

  bool IsValid(std::string* why) const;
};

// Adds one diagnostic per problem to diag; returns true when the plan is fit to run.
bool validatePlan(const Plan& plan, io::Diagnostics& diag, const ValidatorOptions& options = {});

// What `imubench plan check` prints after a successful check.
struct PlanSummary {
  std::string name;
  calib::TableKind kind = calib::TableKind::kTwoAxis;
  double duration_s = 0.0;   // whole plan
  double recording_s = 0.0;  // time with recording on
  int moves = 0;             // executed step counts, repeats unrolled
  int rotates = 0;
  int rate_runs = 0;
  int holds = 0;
  int chamber_steps = 0;
  int segments = 0;         // segments of the expanded Motion
  double min_temp_c = 0.0;  // temperature range visited
  double max_temp_c = 0.0;
};

// Human-readable summary, several lines, no trailing newline.
std::string formatSummary(const PlanSummary& s);

struct PlanCheck {
  // Error "FILE: N problem(s), plan refused" when the plan has errors (listed in diagnostics).
  Status status = Status::Error("not checked");
  std::vector<io::Diagnostic> diagnostics;  // every problem found; empty when ok
  PlanSummary summary;                      // meaningful when ok
};

// Parse + validate + expand a plan file; all errors collected.
PlanCheck checkPlan(const std::string& path, const ValidatorOptions& options = {});
// Same on text already in memory (file_name names it in diagnostics).
PlanCheck checkPlanText(std::string_view text, std::string_view file_name,
                        const ValidatorOptions& options = {});

}  // namespace imubench::plans
