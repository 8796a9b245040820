// Whether a plan may run on a bench: what imubenchd checks before it accepts a plan (start,
// validate) and what the library test checks for every bundled plan and bench file.
//
// A plan fits a bench when its table kind is the bench's, its [table] limits and every
// step's planned profile (the rate and acceleration its expansion computed per axis, what
// the runner sends with each motion) are within the bench's limits, it drives a chamber only
// on a bench with one, and the table's device file lets the daemon set the profile of each
// motion (else the controller would move at its own fixed profile, not the plan's).
#pragma once

#include <string>

#include "base/status.h"
#include "calib/model/motion.h"
#include "daemon/bench_file.h"
#include "plans/plan.h"

namespace imubench::daemon {

// plan: parsed and validated (plans::validatePlan); motion: its expansion (plans::expand).
// Ok, or why not: "<plan file>: why".
Status checkPlanForBench(const plans::Plan& plan, const calib::Motion& motion,
                         const BenchConfig& bench);

}  // namespace imubench::daemon
