// BenchDaemon: calibration (online, final, per point) and the follow-up experiment; the parts
// are listed at the top of daemon/bench_daemon.cpp.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "daemon/bench_daemon.h"
#include "daemon/bench_daemon_internal.h"
#include "daemon/follow_up.h"
#include "daemon/thermal_points.h"
#include "io/verdict.h"
#include "plans/plan.h"

namespace imubench::daemon {

using bench_daemon_internal::loadPlan;
using bench_daemon_internal::unixNow;
using nlohmann::json;

// ---- calibration (daemon/online_engine.h) ---------------------------------------------------

// The run feeds the plan's calibration: the online engine during the run, the final
// calibration when it completes.
void BenchDaemon::attachCalibration(ActiveRun& run, OnlineSetup setup) {
  setup.run_id = run.id;
  run.calibration = setup;
  run.engine = std::make_unique<OnlineEngine>(
      std::move(setup), calibrations_.get(),
      [this, run_id = run.id](const json& fields) { publishEstimate(run_id, fields); });
}

std::optional<OnlineSetup> BenchDaemon::calibrationSetup(const LoadedPlan& loaded,
                                                         std::string* why) {
  const plans::Plan& plan = loaded.plan;
  if (plan.calibration == plans::CalibrationMethod::kNone) return std::nullopt;
  OnlineSetup setup;
  setup.method = plan.calibration;
  setup.db_path = db_path_;
  setup.acceptance = bench_.acceptance;
  setup.known_table_errors = bench_.table_errors;
  if (bench_.explain.follow_up != FollowUpPolicy::kOff) {
    calib::ProposeOptions propose;  // the search's defaults within this bench's table limits
    propose.limits.max_rate_rad_s = bench_.table.limits.max_rate;
    propose.limits.max_accel_rad_s2 = bench_.table.limits.max_accel;
    setup.follow_up = propose;
  }
  io::Recording& meta = setup.meta;
  meta.latitude_deg = bench_.site.latitude_rad * kRadToDeg;
  meta.height_m = bench_.site.height_m;
  meta.gravity_mps2 = bench_.site.gravity_mps2;
  meta.imu_serial = bench_.imu.serial;
  meta.imu_rate_hz = 1.0 / bench_.imu.layout.sample_period_s;
  meta.table_kind = bench_.table.kind;
  if (meta.table_kind == calib::TableKind::kTwoAxis)
    meta.outer_axis_heading_deg = bench_.outer_axis_heading_rad * kRadToDeg;
  meta.segments_from_file = true;
  if (plan.calibration != plans::CalibrationMethod::kPipeline) return setup;
  // The pipeline's direct part: the newest completed run of direct_plan for this IMU.
  const auto runs = store_->listRuns();
  if (!runs.status.ok) {
    *why = "store: " + runs.status.message;
    return std::nullopt;
  }
  for (auto it = runs.value.rbegin(); it != runs.value.rend(); ++it) {
    if (it->state == RunState::kFinished && it->exit_reason == runExitName(RunExit::kCompleted) &&
        it->start.plan_name == plan.direct_plan && it->start.imu_serial == bench_.imu.serial) {
      setup.direct_run = it->id;
      return setup;
    }
  }
  *why = "plan '" + plan.name + "' (calibration = \"pipeline\") needs a completed run of plan '" +
         plan.direct_plan + "' for IMU serial '" + bench_.imu.serial +
         "' on this bench: run that plan first";
  return std::nullopt;
}

// An estimate of the online engine: the run's event log, subscribers (topic "run"), the log.
void BenchDaemon::publishEstimate(std::int64_t run, const json& fields) {
  announce(run, EventSeverity::kInfo, "estimate", fields);
  log_.info("run " + std::to_string(run) + ": estimate after " +
            fields.value("summary", std::string("a step")));
}

void BenchDaemon::announce(std::int64_t run, EventSeverity severity, const std::string& kind,
                           const json& fields) {
  const RunEvent stored{run, unixNow(), severity, kind, fields.dump()};
  if (auto st = store_->addEvent(stored); !st.ok) log_.error("store: " + st.message);
  server_->broadcast(Topic::kRun, kind, fields);
}

// The full calibration of a completed run, off the loop; the results are stored on the loop.
void BenchDaemon::startFinalCalibration(const OnlineSetup& setup) {
  auto job = [this, setup]() -> std::function<void()> {
    FinalCalibration f = finalCalibration(setup);
    return [this, setup, f = std::move(f)] { storeFinalCalibration(setup, f); };
  };
  auto failed = [this, run = setup.run_id](const std::string& what) {
    log_.error("run " + std::to_string(run) + ": calibration failed: " + what);
    server_->broadcast(Topic::kRun, "results", {{"run", run}, {"ok", false}, {"error", what}});
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

void BenchDaemon::startPointCalibrations(std::int64_t run_id) {
  auto job = [this, run_id, db = db_path_, known = bench_.table_errors]() -> std::function<void()> {
    std::string error, serial;
    std::vector<PointCalibration> points;
    auto opened = Store::open(db, StoreOptions{});
    if (opened.status.ok) {
      const auto rec = opened.value->loadRecording(run_id);
      if (rec.status.ok) {
        serial = rec.value.imu_serial;
        points = calibrateTemperaturePoints(rec.value, known);
      } else {
        error = rec.status.message;
      }
    } else {
      error = opened.status.message;
    }
    return [this, run_id, error, serial, points = std::move(points)] {
      const std::string who = "run " + std::to_string(run_id);
      if (!error.empty()) {
        log_.error(who + ": no temperature point results: " + error);
        return;
      }
      int ok = 0;
      for (const PointCalibration& p : points) {
        const auto r = store_->storeResult(run_id, serial, p.temperature_c, "point_coefficients",
                                           pointJson(p).dump());
        if (!r.status.ok) log_.error("store: " + r.status.message);
        ok += p.status.ok ? 1 : 0;
      }
      log_.info(who + ": " + std::to_string(ok) + " of " + std::to_string(points.size()) +
                " temperature points calibrated (IMU " + serial + ")");
      server_->broadcast(
          Topic::kRun, "point_results",
          {{"run", run_id}, {"points", static_cast<int>(points.size())}, {"calibrated", ok}});
    };
  };
  auto failed = [this, run_id](const std::string& what) {
    log_.error("run " + std::to_string(run_id) + ": temperature point calibration failed: " + what);
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

void BenchDaemon::storeFinalCalibration(const OnlineSetup& setup, const FinalCalibration& f) {
  const std::string who = "run " + std::to_string(setup.run_id);
  if (!f.status.ok) {
    log_.error(who + ": no calibration results: " + f.status.message);
    server_->broadcast(Topic::kRun, "results",
                       {{"run", setup.run_id}, {"ok", false}, {"error", f.status.message}});
    return;
  }
  json stored = json::object();
  auto keep = [&](const char* kind, const json& j) {
    const auto r = store_->storeResult(setup.run_id, f.imu_serial, f.temperature_c, kind, j.dump());
    if (!r.status.ok) log_.error("store: " + r.status.message);
    if (r.status.ok) stored[kind] = r.value;
  };
  if (f.calibrated) keep("coefficients", f.coefficients);
  keep("report", f.report);
  keep("verdict", f.verdict);
  if (f.explain) keep("explain", *f.explain);
  if (f.follow_up) {
    if (const auto id = storeFollowUp(setup.run_id, f)) stored[kFollowUpKind] = *id;
  }
  if (f.explain) {
    log_.info(who + ": " + f.explain_summary);
  } else {
    log_.warning(who + ": " + f.explain_error);
  }
  const json pass = f.verdict.value("pass", json());
  log_.info(who + ": calibration " + (f.calibrated ? "done" : "FAILED") + ", verdict " +
            io::verdictWord(f.verdict) + " (IMU " + f.imu_serial + ")");
  server_->broadcast(Topic::kRun, "results",
                     {{"run", setup.run_id},
                      {"ok", true},
                      {"calibrated", f.calibrated},
                      {"pass", pass},
                      {"usable", f.verdict.value("usable", true)},
                      {"imu_serial", f.imu_serial},
                      {"temperature_c", f.temperature_c},
                      {"explain", f.explain ? f.explain_summary : f.explain_error},
                      {"results", stored}});
}

// ---- the follow-up experiment (daemon/follow_up.h) -------------------------------------------

std::optional<std::int64_t> BenchDaemon::storeFollowUp(std::int64_t run_id,
                                                       const FinalCalibration& f) {
  json proposal = *f.follow_up;
  std::string why;
  if (proposal.value("status", "") == "proposed" &&
      !loadPlan(proposal["plan"].value("name", ""), proposal["plan"].value("toml", ""), bench_,
                &why)) {
    // Never stored as runnable what this bench would refuse (its limits, its table).
    proposal["status"] = "refused";
    proposal["reason"] = "the designed plan is refused by this bench: " + why;
    proposal.erase("plan");
  }
  proposal["policy"] = followUpPolicyName(bench_.explain.follow_up);
  const auto r =
      store_->storeResult(run_id, f.imu_serial, f.temperature_c, kFollowUpKind, proposal.dump());
  if (!r.status.ok) {
    log_.error("store: " + r.status.message);
    return std::nullopt;
  }
  const std::string summary = followUpSummary(proposal);
  json fields = {{"run", run_id}, {"status", proposal["status"]}, {"summary", summary}};
  if (proposal.contains("plan")) {
    fields["plan"] = proposal["plan"]["name"];
    fields["duration_s"] = proposal["plan"]["duration_s"];
  }
  fields["groups"] = json::array();
  for (const json& g : proposal["groups"]) {
    fields["groups"].push_back(
        {{"effects", g["effects"]}, {"resolved", g["resolved"]}, {"why", g["why"]}});
  }
  announce(run_id, EventSeverity::kInfo, "follow_up", fields);
  log_.info("run " + std::to_string(run_id) + ": " + summary);
  if (bench_.explain.follow_up == FollowUpPolicy::kQueue && proposal["status"] == "proposed") {
    const Reply q = enqueueFollowUp(nullptr, run_id);
    if (!q.ok)
      log_.warning("run " + std::to_string(run_id) + ": follow-up not queued: " + q.error.message);
  }
  return r.value;
}

Reply BenchDaemon::enqueueFollowUp(const json& id, std::int64_t run_id) {
  ResultFilter filter;
  filter.run_id = run_id;
  const ResultListResult results = store_->results(filter);
  if (!results.status.ok) return errorReply(id, ErrorCode::kInternal, results.status.message);
  const std::string who = "run " + std::to_string(run_id);
  std::optional<json> proposal;
  for (const StoredResult& r : results.value) {
    if (r.kind == kFollowUpKind) proposal = json::parse(r.json, nullptr, false);
  }
  if (!proposal || proposal->is_discarded())
    return errorReply(id, ErrorCode::kNotFound, who + " has no stored follow-up proposal");
  if (proposal->value("status", "") != "proposed") {
    return errorReply(id, ErrorCode::kBadState,
                      who + "'s follow-up holds no plan: " + proposal->value("reason", "?"));
  }
  const std::string name = (*proposal)["plan"].value("name", "");
  std::string why;
  const auto loaded = loadPlan(name, (*proposal)["plan"].value("toml", ""), bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, who + "'s follow-up: " + why);
  QueueEntry entry;
  entry.plan_name = loaded->plan.name;
  entry.source = name;
  entry.plan_toml = loaded->text;
  entry.label = "follow-up of run " + std::to_string(run_id);
  const QueueAddResult added = store_->queueAdd(entry);
  if (!added.status.ok) return errorReply(id, ErrorCode::kInternal, added.status.message);
  const QueuedEvent queued{added.value.entry_id, added.value.position, entry.plan_name};
  log_.info("follow-up of " + who + " queued: entry " + std::to_string(added.value.entry_id) +
            ", position " + std::to_string(added.value.position));
  server_->broadcast(queued);
  // Alone in the queue with the bench idle: it starts now (a held queue stays held).
  if (!run_ && added.value.position == 1) loop_.post([this] { advanceQueue(); });
  return okReply(id, toJson(QueuedReply{queued}));
}

void BenchDaemon::startFollowUpJudgement(std::int64_t run_id) {
  auto job = [this, run_id, db = db_path_, known = bench_.table_errors]() -> std::function<void()> {
    std::optional<FollowUpJudged> j = judgeFollowUp(db, run_id, known);
    return [this, run_id, j = std::move(j)] {
      if (!j) return;  // not a follow-up
      const auto r = store_->storeResult(run_id, j->imu_serial, j->temperature_c,
                                         kFollowUpJointKind, j->joint.dump());
      if (!r.status.ok) log_.error("store: " + r.status.message);
      const bool ok = j->joint.value("ok", false);
      json fields = {{"run", run_id},
                     {"origin_run", j->joint["origin_run"]},
                     {"ok", ok},
                     {"summary", ok ? j->joint.value("summary", "") : j->joint.value("error", "")},
                     {"groups", json::array()}};
      for (const json& g : j->joint["groups"])
        fields["groups"].push_back({{"effects", g["effects"]}, {"verdict", g["verdict"]}});
      announce(run_id, ok ? EventSeverity::kInfo : EventSeverity::kWarning, "follow_up_verdict",
               fields);
      log_.info("run " + std::to_string(run_id) + " (follow-up of run " +
                fields["origin_run"].dump() + "): " + fields["summary"].get<std::string>());
    };
  };
  auto failed = [this, run_id](const std::string& what) {
    log_.error("run " + std::to_string(run_id) + ": follow-up judgement failed: " + what);
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

}  // namespace imubench::daemon
