// Helpers shared by the plans/ tests.
#pragma once

#include <string>
#include <string_view>

#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::plans::test {

inline const std::string kLibraryDir = IMUBENCH_PLAN_LIBRARY_DIR;
inline const std::string kBrokenDir = IMUBENCH_BROKEN_PLANS_DIR;

// A two-axis table header for inline test plans (20 deg/s, 10 deg/s^2).
inline constexpr std::string_view kTwoAxisHeader = R"(
[plan]
name = "test"

[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
)";

inline std::string twoAxis(std::string_view steps) {
  return std::string(kTwoAxisHeader) + std::string(steps);
}

// Diagnostics of a check as one string (for failure messages and substring tests).
inline std::string allDiagnostics(const PlanCheck& c) {
  std::string s;
  for (const auto& d : c.diagnostics) s += d.str() + "\n";
  return s;
}

}  // namespace imubench::plans::test
