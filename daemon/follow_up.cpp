#include "daemon/follow_up.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <span>

#include "daemon/online_engine.h"
#include "daemon/store.h"
#include "io/plan_writer.h"
#include "io/sim_recording.h"
#include "nav/rotation.h"
#include "plans/proposal.h"

namespace imubench::daemon {
namespace {

using nlohmann::json;

// A joint judgement that could not be made, and why.
json jointFailure(const json& origin_run, std::int64_t run, const std::string& error) {
  return {{"format", "imubench-follow-up-joint/1"},
          {"origin_run", origin_run},
          {"run", run},
          {"ok", false},
          {"groups", json::array()},
          {"error", error}};
}

// NaN (a parameter explain holds) as null.
json number(double v) {
  return std::isfinite(v) ? json(v) : json();
}

// Why no plan: the groups no plan within the limits separates, each with its reason.
std::string refusalReason(const calib::ProposeResult& p) {
  std::string why;
  for (const calib::ProposedGroup& g : p.groups) {
    if (g.resolved) continue;
    std::string ids;
    for (const std::string& e : g.effects) ids += (ids.empty() ? "" : " + ") + e;
    why += (why.empty() ? "" : "; ") + ids + ": " + g.why;
  }
  return why.empty() ? "no plan within the bench limits separates the groups" : why;
}

// A group explain reported unseparable whose principal angle on the recording, as the design
// evaluates it, is already above the limit: the design did not model what explain judged (e.g.
// another angle_harmonic variant), so its claim that the plan separates the group is not
// trusted. Seen on the virtual bench (20x, direct plan): angle_harmonic proposed as separated
// (41 -> 70 deg) and still unseparable in the joint analysis after the follow-up ran.
void distrustDisagreements(calib::ProposeResult* p) {
  for (calib::ProposedGroup& g : p->groups) {
    const double limit = p->angleLimitFor(g);
    if (!g.unseparable || !g.resolved || g.angle_before_rad < limit) continue;
    g.resolved = false;
    char why[240];
    std::snprintf(why, sizeof why,
                  "not claimed: the design sees this group separable on the recording already "
                  "(%.3g deg, limit %.3g deg) while explain reports it unseparable, so it did not "
                  "model what explain judged",
                  g.angle_before_rad * kRadToDeg, limit * kRadToDeg);
    g.why = why;
  }
}

const calib::ExplainAccepted* acceptedEffect(const calib::ExplainResult& r, const std::string& id) {
  for (const calib::ExplainAccepted& a : r.accepted) {
    if (a.effect == id) return &a;
  }
  return nullptr;
}

// The proposal's predicted joint sigma of a parameter (NaN: none).
double predictedJoint(const json& group, const std::string& name) {
  for (const json& p : group.value("parameters", json::array())) {
    if (p.value("name", "") == name && p["sigma_joint"].is_number())
      return p["sigma_joint"].get<double>();
  }
  return std::nan("");
}

// One unseparable group of the origin after the joint analysis.
json jointGroup(const json& group, const calib::ExplainResult& joint) {
  const auto effects = group["effects"].get<std::vector<std::string>>();
  bool still = false;
  for (const calib::ExplainUnseparable& u : joint.unseparable) still |= u.effects == effects;
  json out = {{"effects", effects},
              {"verdict", still ? "still unseparable" : "resolved"},
              {"parameters", json::array()}};
  if (still) return out;
  for (const std::string& e : effects) {
    const calib::ExplainAccepted* a = acceptedEffect(joint, e);
    if (a == nullptr) {
      out["not_warranted"].push_back(e);  // separated, and the data do not want it
      continue;
    }
    for (std::size_t k = 0; k < a->values.size(); ++k) {
      out["parameters"].push_back(
          {{"name", a->flat_names[k]},
           {"value", number(a->values[k])},
           {"sigma", number(a->sigmas[k])},
           {"sigma_predicted", number(predictedJoint(group, a->flat_names[k]))}});
    }
  }
  return out;
}

std::optional<plans::CalibrationMethod> methodNamed(const std::string& name) {
  for (auto m : {plans::CalibrationMethod::kDirect, plans::CalibrationMethod::kIndirect,
                 plans::CalibrationMethod::kPipeline}) {
    if (name == plans::calibrationMethodName(m)) return m;
  }
  return std::nullopt;
}

// The newest stored proposal of this IMU whose plan is run's plan (nullopt: none).
std::optional<json> proposalOf(Store& store, const RunInfo& run) {
  ResultFilter filter;
  filter.imu_serial = run.start.imu_serial;
  const ResultListResult results = store.results(filter);
  if (!results.status.ok) return std::nullopt;
  for (auto it = results.value.rbegin(); it != results.value.rend(); ++it) {
    if (it->kind != kFollowUpKind || it->run_id >= run.id) continue;
    json j = json::parse(it->json, nullptr, false);
    if (j.is_discarded() || j.value("status", "") != "proposed") continue;
    if (j["plan"].value("toml", "") == run.start.plan_toml) return j;
  }
  return std::nullopt;
}

// The origin's recording (complete segments) and its calibration as its results were made.
json judgeWith(Store& store, const json& proposal, const io::Recording& follow_up,
               std::int64_t run_id, const std::optional<calib::TableErrors>& known_table_errors,
               const calib::ExplainOptions& options) {
  const std::int64_t origin = proposal.value("run", std::int64_t{0});
  const auto method = methodNamed(proposal.value("method", ""));
  const std::string who = "origin run " + std::to_string(origin);
  if (!method) return jointFailure(origin, run_id, who + " had no calibration");
  auto rec = store.loadRecording(origin);
  if (!rec.status.ok) return jointFailure(origin, run_id, who + ": " + rec.status.message);
  const io::Recording origin_rec = completeSegmentsOnly(std::move(rec.value), nullptr);
  std::optional<io::Recording> direct;
  if (proposal["direct_run"].is_number_integer()) {
    const std::int64_t d = proposal["direct_run"].get<std::int64_t>();
    auto dr = store.loadRecording(d);
    if (!dr.status.ok) {
      return jointFailure(origin, run_id,
                          "direct run " + std::to_string(d) + ": " + dr.status.message);
    }
    direct = completeSegmentsOnly(std::move(dr.value), nullptr);
  }
  const RunCalibration c =
      calibrateRun(*method, origin_rec, direct ? &*direct : nullptr, known_table_errors);
  if (!c.status.ok)
    return jointFailure(origin, run_id, who + ": its calibration failed: " + c.status.message);
  const io::CalibrationView origin_view(origin_rec), follow_view(follow_up);
  calib::ExplainInput first, second;
  first.recording() = origin_view.view();
  first.baseline = c.coefficients;
  first.baseline_method = c.baseline_method;
  first.baseline_table_params = c.table_params;
  second.recording() = follow_view.view();
  return jointFollowUp(proposal, first, second, run_id, options);
}

}  // namespace

std::optional<FollowUpJudged> judgeFollowUp(
    const std::string& db_path, std::int64_t run_id,
    const std::optional<calib::TableErrors>& known_table_errors,
    const calib::ExplainOptions& options) {
  auto opened = Store::open(db_path, StoreOptions{});
  if (!opened.status.ok) return std::nullopt;
  Store& store = *opened.value;
  const RunInfoResult run = store.runInfo(run_id);
  if (!run.status.ok) return std::nullopt;
  const std::optional<json> proposal = proposalOf(store, run.value);
  if (!proposal) return std::nullopt;
  FollowUpJudged out;
  out.imu_serial = run.value.start.imu_serial;
  auto rec = store.loadRecording(run_id);
  if (!rec.status.ok) {
    out.joint = jointFailure(proposal->value("run", json()), run_id, rec.status.message);
    return out;
  }
  const io::Recording follow_up = completeSegmentsOnly(std::move(rec.value), nullptr);
  if (const auto t = runTemperature(follow_up)) out.temperature_c = *t;
  out.joint = judgeWith(store, *proposal, follow_up, run_id, known_table_errors, options);
  return out;
}

std::string followUpPlanName(std::int64_t run_id) {
  return "follow_up_of_run_" + std::to_string(run_id);
}

std::optional<json> proposeFollowUp(const calib::ExplainInput& input,
                                    const calib::ExplainResult& result,
                                    const calib::ExplainOptions& explain_options,
                                    const FollowUpSetup& setup) {
  if (result.unseparable.empty()) return std::nullopt;
  json out = {{"format", "imubench-follow-up/1"},
              {"run", setup.run_id},
              {"method", plans::calibrationMethodName(setup.method)},
              {"direct_run", setup.direct_run ? json(*setup.direct_run) : json()},
              {"limits",
               {{"max_rate_deg_s", setup.propose.limits.max_rate_rad_s * kRadToDeg},
                {"max_accel_deg_s2", setup.propose.limits.max_accel_rad_s2 * kRadToDeg},
                {"max_duration_s", setup.propose.max_duration_s}}},
              {"groups", json::array()},
              {"notes", json::array()}};
  calib::ProposeResult p;
  try {
    p = calib::proposePlan(input, result, explain_options, setup.propose,
                           plans::expandProposedPlan);
  } catch (const std::exception& e) {
    p.status = Status::Error(std::string("the design failed: ") + e.what());
  }
  if (!p.status.ok) {
    out["status"] = "refused";
    out["reason"] = p.status.message;
    return out;
  }
  distrustDisagreements(&p);
  for (const calib::ProposedGroup& g : p.groups) out["groups"].push_back(calib::toJson(g, p));
  out["notes"] = p.notes;
  const bool any_resolved = std::any_of(p.groups.begin(), p.groups.end(),
                                        [](const auto& g) { return g.unseparable && g.resolved; });
  if (p.plan.blocks.empty() || !any_resolved) {
    out["status"] = "refused";
    out["reason"] = refusalReason(p);
    return out;
  }
  p.plan.name = followUpPlanName(setup.run_id);
  json blocks = json::array();
  for (const calib::ProposedBlock& b : p.plan.blocks) blocks.push_back(b.purpose);
  out["status"] = "proposed";
  out["plan"] = {{"name", p.plan.name},
                 {"toml", io::proposedPlanToml(p.plan)},
                 {"duration_s", p.duration_s},
                 {"blocks", blocks}};
  return out;
}

std::string followUpSummary(const json& f) {
  std::string groups;
  for (const json& g : f.value("groups", json::array())) {
    if (!g.value("unseparable", false)) continue;
    std::string ids;
    for (const json& e : g["effects"]) ids += (ids.empty() ? "" : " + ") + e.get<std::string>();
    groups += (groups.empty() ? "" : ", ") + ids + (g.value("resolved", false) ? "" : " (no plan)");
  }
  if (f.value("status", "") != "proposed")
    return "follow-up refused: " + f.value("reason", std::string("?"));
  const json& plan = f["plan"];
  return "follow-up proposed: plan '" + plan.value("name", "") + "' (" +
         std::to_string(static_cast<long>(plan.value("duration_s", 0.0))) + " s) for " + groups;
}

json jointFollowUp(const json& proposal, const calib::ExplainInput& origin,
                   const calib::ExplainInput& follow_up, std::int64_t follow_up_run,
                   const calib::ExplainOptions& options) {
  const json origin_run = proposal.value("run", json());
  const std::array<calib::ExplainInput, 2> inputs = {origin, follow_up};
  calib::ExplainResult r;
  try {
    r = calib::explainRecordings(std::span<const calib::ExplainInput>(inputs), options);
  } catch (const std::exception& e) {
    r.status = Status::Error(std::string("the analysis failed: ") + e.what());
  }
  if (!r.status.ok)
    return jointFailure(origin_run, follow_up_run, "joint explain: " + r.status.message);
  json out = jointFailure(origin_run, follow_up_run, "");
  out.erase("error");
  out["ok"] = true;
  std::string summary;
  for (const json& g : proposal.value("groups", json::array())) {
    if (!g.value("unseparable", false)) continue;
    json j = jointGroup(g, r);
    std::string ids;
    for (const json& e : j["effects"]) ids += (ids.empty() ? "" : " + ") + e.get<std::string>();
    summary += (summary.empty() ? "" : "; ") + ids + ": " + j["verdict"].get<std::string>();
    out["groups"].push_back(std::move(j));
  }
  out["summary"] = summary.empty() ? "no unseparable group to judge" : summary;
  out["report"] = calib::toJson(r);
  return out;
}

}  // namespace imubench::daemon
