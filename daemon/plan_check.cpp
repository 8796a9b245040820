#include "daemon/plan_check.h"

#include <sstream>
#include <utility>

#include "daemon/plan_runner.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

// Bench limits are compared with a relative tolerance: the same value written in other units
// may differ in the last bits.
constexpr double kLimitTolerance = 1e-9;

bool above(double value, double limit) {
  return value > limit * (1.0 + kLimitTolerance);
}

std::string benchLimits(const BenchConfig& bench) {
  std::ostringstream ss;
  ss << bench.table.limits.max_rate * kRadToDeg << " deg/s, "
     << bench.table.limits.max_accel * kRadToDeg << " deg/s^2";
  return ss.str();
}

// The plan's [table] limits per axis.
Status checkPlanLimits(const plans::Plan& plan, const BenchConfig& bench) {
  const auto names = plans::axisNames(plan.table.kind);
  for (int a = 0; a < calib::axisCount(plan.table.kind); ++a) {
    const plans::EffectiveLimits lim = plans::limitsFor(plan.table, a);
    if (above(lim.max_rate.value_or(0.0), bench.table.limits.max_rate) ||
        above(lim.max_accel.value_or(0.0), bench.table.limits.max_accel)) {
      return Status::Error(plan.file + ": axis " + std::string(names[static_cast<size_t>(a)]) +
                           " asks for more than this bench allows (" + benchLimits(bench) + ")");
    }
  }
  return Status::Ok();
}

// Every step's planned profile (what the runner will command).
Status checkStepProfiles(const plans::Plan& plan, const calib::Motion& motion,
                         const BenchConfig& bench) {
  const auto names = plans::axisNames(plan.table.kind);
  for (const RunStep& s : runSteps(motion)) {
    for (std::size_t a = 0; a < s.limits.size() && a < names.size(); ++a) {
      const drivers::MotionLimits& m = s.limits[a];
      if (m.rate == 0.0 && m.accel == 0.0) continue;
      if (!bench.table.profileSettable()) {
        return Status::Error(plan.file + ": step '" + s.label + "' moves the table, but " +
                             bench.table.file + " gives no way to set the rate and acceleration " +
                             "of a motion (rate_limit/accel_limit registers or set_rate_limit/" +
                             "set_accel_limit commands): the table would not follow the plan");
      }
      if (above(m.rate, bench.table.limits.max_rate) ||
          above(m.accel, bench.table.limits.max_accel)) {
        std::ostringstream ss;
        ss << plan.file << ": step '" << s.label << "' turns the " << names[a] << " axis at "
           << m.rate * kRadToDeg << " deg/s, " << m.accel * kRadToDeg
           << " deg/s^2: more than this bench allows (" << benchLimits(bench) << ")";
        return Status::Error(ss.str());
      }
    }
  }
  return Status::Ok();
}

}  // namespace

Status checkPlanForBench(const plans::Plan& plan, const calib::Motion& motion,
                         const BenchConfig& bench) {
  if (plan.table.kind != bench.table.kind) {
    return Status::Error(plan.file + ": the plan is for a " +
                         plans::tableKindName(plan.table.kind) + " table, this bench has a " +
                         plans::tableKindName(bench.table.kind) + " table");
  }
  if (Status f = checkPlanLimits(plan, bench); !f.ok) return f;
  if (plan.chamber && !bench.chamber) {
    return Status::Error(plan.file + ": the plan drives a chamber and this bench has none");
  }
  return checkStepProfiles(plan, motion, bench);
}

}  // namespace imubench::daemon
