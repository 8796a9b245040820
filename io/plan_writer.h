// Plan TOML (docs/plan-format.md) of a generated plan (calib/explain/explain_propose.h
// ProposedPlan): [plan], [table] with the limits the plan asks for, and every block's steps under a
// comment saying what the block is for. The text passes `imubench plan check` when the plan's moves
// avoid 180 deg (ProposedPlan's generator splits them).
#pragma once

#include <optional>
#include <string>

#include "calib/explain/explain_propose.h"
#include "io/toml_diagnostics.h"

namespace imubench::io {

std::string proposedPlanToml(const calib::ProposedPlan& plan);

// The table limits of a bench file (daemon/bench_file.h [table] max_rate / max_accel, the
// bench's own limits), each left at its default in `limits` when the file does not give it.
// Only these keys are read (the device file's own limits are the daemon's to apply); a bad
// value is a diagnostic naming file:line and nullopt.
std::optional<calib::ProposeLimits> benchTableLimits(const std::string& path,
                                                     calib::ProposeLimits limits,
                                                     Diagnostics& diag);

}  // namespace imubench::io
