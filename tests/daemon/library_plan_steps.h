// The executed steps of a bundled plan (plans/library/), for the runner tests.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "daemon/plan_runner.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::daemon::testing {

inline std::vector<RunStep> libraryPlanSteps(const std::string& file) {
  const std::string path = std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/" + file;
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  const auto ex = plans::expand(*plan);
  EXPECT_TRUE(ex.status.ok) << ex.status.message;
  return runSteps(ex.motion);
}

}  // namespace imubench::daemon::testing
