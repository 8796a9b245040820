// A generated plan (calib/explain/explain_propose.h ProposedPlan) through the one plan path:
// written as plan TOML (io/plan_writer.h), parsed, validated and expanded like any plan file, so
// what the proposer evaluates is what `imubench plan check` and the daemon see.
#pragma once

#include "base/status.h"
#include "calib/explain/explain_propose.h"
#include "calib/model/motion.h"

namespace imubench::plans {

// The Motion of the plan, or why its text is refused (the diagnostics, file:line).
Result<calib::Motion> expandProposedPlan(const calib::ProposedPlan& plan);

}  // namespace imubench::plans
