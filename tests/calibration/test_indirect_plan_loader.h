// Test helper: a bundled plan (plans/library/NAME.toml) parsed, validated and expanded.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "calib/model/motion.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::calib::testing {

inline Motion libraryMotion(const std::string& name) {
  const std::string path = std::string(IMUBENCH_PLAN_DIR) + "/" + name + ".toml";
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  EXPECT_TRUE(plan.has_value()) << diag.str();
  if (!plan) return {};
  EXPECT_TRUE(plans::validatePlan(*plan, diag)) << diag.str();
  plans::ExpandResult r = plans::expand(*plan);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return r.motion;
}

}  // namespace imubench::calib::testing
