#include "plans/proposal.h"

#include "io/plan_writer.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::plans {

Result<calib::Motion> expandProposedPlan(const calib::ProposedPlan& plan) {
  const std::string text = io::proposedPlanToml(plan);
  io::Diagnostics diag("<proposed plan>");
  const std::optional<Plan> parsed = parsePlan(text, "<proposed plan>", diag);
  if (!parsed || !validatePlan(*parsed, diag)) {
    return Result<calib::Motion>::Error("the generated plan is refused: " + diag.str());
  }
  ExpandResult r = expand(*parsed);
  if (!r.status.ok) return Result<calib::Motion>::Error(r.status.message);
  return {Status::Ok(), std::move(r.motion)};
}

}  // namespace imubench::plans
