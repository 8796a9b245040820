#include "tools/cli_explain_propose.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "calib/explain/explain_propose.h"
#include "io/plan_writer.h"
#include "nav/rotation.h"
#include "plans/proposal.h"
#include "plans/validator.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

calib::ProposeOptions proposeOptions(const ProposeCliOptions& o) {
  calib::ProposeOptions po;
  if (!o.bench.empty()) {
    io::Diagnostics diag(o.bench);
    const auto limits = io::benchTableLimits(o.bench, po.limits, diag);
    if (!limits) throw CommandFailed(diag.str(), 2);
    po.limits = *limits;
  }
  if (o.max_duration_s) po.max_duration_s = *o.max_duration_s;
  if (o.precision) po.relative_precision = *o.precision;
  std::string why;
  if (!po.IsValid(&why)) throw CommandFailed("propose options: " + why, 2);
  return po;
}

void printSigmas(const calib::ProposedGroup& g) {
  for (std::size_t k = 0; k < g.flat_names.size(); ++k) {
    std::printf("    %-36s predicted sigma %.3g -> %.3g", g.flat_names[k].c_str(),
                g.sigma_before[k], g.sigma_after[k]);
    if (k < g.sigma_joint.size()) std::printf(" (with this recording: %.3g)", g.sigma_joint[k]);
    if (k < g.sigma_target.size()) std::printf(" (wanted <= %.3g)", g.sigma_target[k]);
    std::printf("%s\n", std::isnan(g.sigma_after[k]) ? " (held: explain holds it)" : "");
  }
}

void printGroup(const calib::ProposedGroup& g, const calib::ProposeResult& p) {
  const double limit = p.angleLimitFor(g);
  std::string names;
  for (const std::string& e : g.effects) names += (names.empty() ? "" : " + ") + e;
  std::printf(
      "  %s (%s): %s\n", names.c_str(), g.unseparable ? "unseparable" : "short of the precision",
      g.resolved ? (g.unseparable ? "separated by the plan" : "precise enough with the plan")
                 : ("NOT RESOLVED: " + g.why).c_str());
  if (g.unseparable) {
    std::printf(g.effects.size() > 1
                    ? "    principal angle %.3g -> %.3g deg (limit %.3g deg)\n"
                    : "    angle to the baseline's columns %.3g -> %.3g deg (limit %.3g deg)\n",
                g.angle_before_rad * kRadToDeg, g.angle_after_rad * kRadToDeg, limit * kRadToDeg);
  }
  std::printf("    the plan adds %.0f s for it:\n", g.added_duration_s);
  for (const std::string& a : g.added) std::printf("      - %s\n", a.c_str());
  printSigmas(g);
}

void writePlan(const std::string& path, const calib::ProposedPlan& plan) {
  {
    std::ofstream f(path);
    f << io::proposedPlanToml(plan);
    if (!f) throw CommandFailed("cannot write " + path);
  }
  const plans::PlanCheck check = plans::checkPlan(path);
  if (!check.status.ok) throw CommandFailed("the written plan is refused: " + check.status.message);
}

}  // namespace

// The proposal for the --json report: the plan file (null when none was written), its
// duration, each group with its predicted sigmas, the notes.
nlohmann::json proposalJson(const calib::ProposeResult& p, const std::string& written) {
  nlohmann::json groups = nlohmann::json::array();
  for (const calib::ProposedGroup& g : p.groups) groups.push_back(calib::toJson(g, p));
  return {{"plan", written.empty() ? nlohmann::json(nullptr) : nlohmann::json(written)},
          {"duration_s", p.duration_s},
          {"nothing_to_propose", p.nothing_to_propose},
          {"groups", groups},
          {"notes", p.notes}};
}

nlohmann::json proposeFromExplain(const ProposeCliOptions& o, const calib::ExplainInput& input,
                                  const calib::ExplainResult& result,
                                  const calib::ExplainOptions& eo) {
  const calib::ProposeOptions po = proposeOptions(o);
  const calib::ProposeResult p =
      calib::proposePlan(input, result, eo, po, plans::expandProposedPlan);
  if (!p.status.ok) throw CommandFailed("propose: " + p.status.message);
  if (p.nothing_to_propose) {
    std::printf(
        "propose: nothing to propose (no unseparable group, every accepted effect within "
        "%.3g of its size); no plan written\n",
        po.relative_precision);
    return proposalJson(p, "");
  }
  std::printf("propose (limits %.3g deg/s, %.3g deg/s^2, at most %.0f s):\n",
              po.limits.max_rate_rad_s * kRadToDeg, po.limits.max_accel_rad_s2 * kRadToDeg,
              po.max_duration_s);
  for (const calib::ProposedGroup& g : p.groups) printGroup(g, p);
  for (const std::string& n : p.notes) std::printf("  note: %s\n", n.c_str());
  if (p.plan.blocks.empty()) {
    std::printf("propose: no plan written (why: the groups and notes above)\n");
    return proposalJson(p, "");
  }
  writePlan(o.out, p.plan);
  std::printf("propose: plan written to %s (%zu blocks, %.0f s); it passes imubench plan check\n",
              o.out.c_str(), p.plan.blocks.size(), p.duration_s);
  return proposalJson(p, o.out);
}

}  // namespace imubench::tools
