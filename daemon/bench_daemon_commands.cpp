// BenchDaemon: the control socket's commands, starting and resuming runs; the parts are listed
// at the top of daemon/bench_daemon.cpp.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "daemon/bench_daemon.h"
#include "daemon/bench_daemon_internal.h"
#include "daemon/thermal_points.h"

namespace imubench::daemon {

using bench_daemon_internal::loadPlan;
using bench_daemon_internal::unixNow;
using nlohmann::json;

// ---- control socket ------------------------------------------------------------------------

std::optional<Reply> BenchDaemon::handle(const Request& request, ClientId client) {
  switch (request.command) {
    case Command::kStart:
      return startPlan(request, client);
    case Command::kPause:
    case Command::kResume:
    case Command::kAbort:
    case Command::kStop:
      return runnerCommand(request);
    case Command::kRearm:
      return rearm(request);
    case Command::kStatus:
      return status();
    case Command::kListPlans:
      return listPlans(request, client);
    case Command::kValidatePlan:
      return validatePlan(request, client);
    case Command::kResults:
      return results(request);
    case Command::kExport:
      return exportRun(request, client);
    case Command::kQueueList:
      return queueReply(request.id);
    case Command::kQueueMove:
    case Command::kQueueRemove:
      return queueChange(request);
    case Command::kQueueResume:
      return startQueued(request.id);
    case Command::kQueueAccept:
      return enqueueFollowUp(request.id, std::get<QueueAcceptArgs>(request.args).run);
    case Command::kPing:
    case Command::kSubscribe:
    case Command::kUnsubscribe:
      break;  // the server answers these itself
  }
  return errorReply(request.id, ErrorCode::kInternal, "unhandled command");
}

// The plan's text: inline now, or read from the plan library off the loop and then answered
// through the server (nullopt now). Paths outside the library are refused untouched.
std::optional<Reply> BenchDaemon::withPlanText(const Request& request, ClientId client,
                                               const PlanSource& source, const PlanUse& use) {
  if (source.kind == PlanSource::Kind::kInline)
    return use(source.name.empty() ? "inline plan" : source.name, source.text);
  if (auto why = refuseLibraryPath(source.text, plans_->options().plan_dir))
    return errorReply(request.id, ErrorCode::kBadArgument, "plan.path: " + *why);
  auto done = [this, request, client, path = source.text, use](const PlanFile& file) {
    if (!server_->connected(client)) {
      log_.info("plan " + path + " read for a client that has gone; dropped");
      return;
    }
    Reply r = file.status.ok ? use(path, file.text)
                             : errorReply(request.id, ErrorCode::kBadPlan, file.status.message);
    r.id = request.id;
    server_->sendReply(client, r);
  };
  std::string why;
  if (!plans_->read(source.text, done, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

std::optional<Reply> BenchDaemon::startPlan(const Request& request, ClientId client) {
  if (run_ && !std::get<StartArgs>(request.args).options.queue) return busyReply(request);
  return withPlanText(request, client, std::get<StartArgs>(request.args).plan,
                      [this, request](const std::string& name, const std::string& text) {
                        return startLoaded(request, name, text);
                      });
}

Reply BenchDaemon::busyReply(const Request& request) const {
  return errorReply(request.id, ErrorCode::kBusy,
                    "run " + std::to_string(run_->id) + " (" + run_->plan_name + ") is " +
                        runnerStateName(run_->runner->state()) + "; one plan at a time");
}

Reply BenchDaemon::startLoaded(const Request& request, const std::string& name,
                               const std::string& text) {
  const auto& args = std::get<StartArgs>(request.args);
  if (run_ && !args.options.queue) return busyReply(request);  // another start won the race
  std::string why;
  auto loaded = loadPlan(name, text, bench_, &why);
  if (!loaded) return errorReply(request.id, ErrorCode::kBadPlan, why);
  if (args.options.dry_run) {
    const PlanSummary summary{loaded->plan.name,
                              static_cast<std::int64_t>(runSteps(loaded->motion).size()),
                              loaded->motion.duration};
    return okReply(request.id, toJson(DryRunReply{true, summary}));
  }
  if (args.options.queue) {
    const auto waiting = store_->queueList();
    if (!waiting.status.ok)
      return errorReply(request.id, ErrorCode::kInternal, waiting.status.message);
    if (run_ || !waiting.value.empty()) return enqueue(request, name, *loaded);
  }
  return launch(*loaded, request.id);
}

// The plan's runner with the bench's safety settings.
std::unique_ptr<PlanRunner> BenchDaemon::makeRunner(const LoadedPlan& loaded) {
  RunnerOptions ro;
  ro.comm_timeout_s = bench_.safety.comm_timeout_s;
  ro.imu_timeout_s = bench_.safety.imu_timeout_s;
  if (bench_.chamber) {
    ro.chamber_safe_setpoint_c = bench_.chamber->safe_setpoint_c;
    ro.chamber_over_temperature_c = bench_.chamber->over_temperature_c;
  }
  return std::make_unique<PlanRunner>(runSteps(loaded.motion), ro, *port_);
}

// Starts a validated plan now (no run going): the runner, then the run's record. The reply to
// the request with id `id`.
Reply BenchDaemon::launch(const LoadedPlan& loaded, const json& id) {
  std::string why;
  std::optional<OnlineSetup> calibration = calibrationSetup(loaded, &why);
  if (!why.empty()) return errorReply(id, ErrorCode::kBadState, why);
  auto runner = makeRunner(loaded);
  // Started before the run is recorded: a bench that cannot move (controller unreachable,
  // emergency stop not cleared) gets no run record, nothing was attempted. The runner's
  // first events wait in its queue until the run has an id.
  if (const Status started = runner->start(wallNow()); !started.ok) {
    return errorReply(id, ErrorCode::kBadState, started.message);
  }
  RunStart start;
  start.plan_name = loaded.plan.name;
  start.plan_toml = loaded.text;
  start.bench_name = bench_.name;
  start.imu_serial = bench_.imu.serial;
  start.imu_rate_hz = 1.0 / bench_.imu.layout.sample_period_s;
  start.latitude_deg = bench_.site.latitude_rad * kRadToDeg;
  start.height_m = bench_.site.height_m;
  start.gravity_mps2 = bench_.site.gravity_mps2;
  start.table_kind = bench_.table.kind;
  if (start.table_kind == calib::TableKind::kTwoAxis) {
    start.outer_axis_heading_deg = bench_.outer_axis_heading_rad * kRadToDeg;
  }
  auto begun = store_->beginRun(start);
  if (!begun.status.ok) return errorReply(id, ErrorCode::kInternal, begun.status.message);
  auto run = std::make_unique<ActiveRun>();
  run->id = begun.value;
  run->plan_name = loaded.plan.name;
  run->runner = std::move(runner);
  run->writer = std::make_unique<RunWriter>(*store_, begun.value);
  if (calibration) attachCalibration(*run, std::move(*calibration));
  run_ = std::move(run);
  publish(run_->runner->takeEvents());
  log_.info("run " + std::to_string(run_->id) + " started: plan '" + run_->plan_name + "'");
  const PlanSummary summary{run_->plan_name,
                            static_cast<std::int64_t>(run_->runner->steps().size()),
                            run_->runner->plannedTotalS()};
  return okReply(id, toJson(StartReply{run_->id, summary, std::nullopt}));
}

// The newest wall time the run's stored events vouch for as no later than its last stored
// sample (+ the writer's unflushed tail): the run's start, every event but the "interrupted"
// one a restarted daemon adds at start-up. Unknown events: the run's start alone.
double BenchDaemon::timeSinceLastStoredSample(const RunInfo& run) {
  double last_wall = run.started_unix_s;
  const EventListResult events = store_->events(run.id);
  if (events.status.ok) {
    for (const RunEvent& e : events.value) {
      if (e.kind != "interrupted") last_wall = std::max(last_wall, e.wall_unix_s);
    }
  } else {
    log_.warning("run " + std::to_string(run.id) + ": " + events.status.message);
  }
  // A kill -9 loses the rows still buffered: the last stored sample may precede the newest
  // event by up to the writer's unflushed span (of sample time; the IMU's clock runs no
  // slower than the receive clock).
  return unixNow() - last_wall + store_->options().max_unflushed_s;
}

std::string BenchDaemon::continueImuTimeAxis(const RunInfo& run, const ResumePoint& point) {
  if (!imu_last_t_) return "the IMU is silent; resume when it streams";
  if (!point.last_imu_t || *imu_last_t_ > *point.last_imu_t) return "";
  const drivers::ImuDecoder& decoder = imu_->decoder();
  const double elapsed = timeSinceLastStoredSample(run);
  const drivers::TimeWrapResolution wraps = drivers::resolveTimeWraps(
      *imu_last_t_, *point.last_imu_t, decoder.timeWrapPeriod(), elapsed, decoder.options());
  if (!wraps.wraps) {
    return wraps.why + "; start a new run";
  }
  const double shift = static_cast<double>(*wraps.wraps) * *decoder.timeWrapPeriod();
  imu_->shiftTimeWraps(*wraps.wraps);
  imu_last_t_ = *imu_last_t_ + shift;
  log_.info("run " + std::to_string(run.id) + ": the IMU time stamp wrapped " +
            std::to_string(*wraps.wraps) + " time(s) since the run's last sample; its time " +
            "axis goes on " + std::to_string(shift) + " s later");
  return "";
}

// Crash resume: run `run_id` (interrupted by a crash, a power loss or a stop, or aborted or
// faulted) goes on from the step after its last finished one (the start of its temperature
// point in a thermal plan: plan_runner.h resumeStep), on the same bench and IMU and one time axis;
// the rows already stored stay, the new ones append to the same run.
Reply BenchDaemon::resumeInterrupted(const Request& request, std::int64_t run_id) {
  const json& id = request.id;
  const std::string which = "run " + std::to_string(run_id);
  if (run_) return busyReply(request);
  const RunInfoResult info = store_->runInfo(run_id);
  if (!info.status.ok) return errorReply(id, ErrorCode::kNotFound, info.status.message);
  const RunInfo& run = info.value;
  if (!runResumable(run.state)) {
    return errorReply(id, ErrorCode::kBadState,
                      which + " is " + runStateName(run.state) +
                          "; only an interrupted, aborted or faulted run can be resumed (a "
                          "paused one: resume)");
  }
  if (run.start.bench_name != bench_.name || run.start.imu_serial != bench_.imu.serial) {
    return errorReply(id, ErrorCode::kBadState,
                      which + " ran on bench '" + run.start.bench_name + "' with IMU '" +
                          run.start.imu_serial + "'; this is bench '" + bench_.name +
                          "' with IMU '" + bench_.imu.serial + "'");
  }
  std::string why;
  const auto loaded = loadPlan(run.start.plan_name, run.start.plan_toml, bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, which + ": " + why);
  ResumePoint point = store_->resumePoint(run_id);
  if (!point.status.ok) return errorReply(id, ErrorCode::kInternal, point.status.message);
  // One time axis: the IMU must still count on from where the run's samples end.
  if (const std::string axis = continueImuTimeAxis(run, point); !axis.empty()) {
    return errorReply(id, ErrorCode::kBadState, which + ": " + axis);
  }
  why.clear();
  std::optional<OnlineSetup> calibration = calibrationSetup(*loaded, &why);
  if (!why.empty()) return errorReply(id, ErrorCode::kBadState, which + ": " + why);
  auto runner = makeRunner(*loaded);
  // An interrupted temperature point restarts at its chamber step; elsewhere no rotation may
  // touch the gap the interruption left (plan_runner.h resumeAfterGap): the void segments go.
  const GapRestart restart = resumeAfterGap(runner->steps(), point.last_finished_step);
  const int next = restart.step;
  const bool done = next >= static_cast<int>(runner->steps().size());
  if (!done && restart.first_void <= point.last_finished_step) {
    if (auto st = discardBeforeResume(run_id, runner->steps(), restart, &point); !st.ok)
      return errorReply(id, ErrorCode::kInternal, st.message);
  }
  if (!done) {
    if (const Status started = runner->startAt(wallNow(), next); !started.ok) {
      return errorReply(id, ErrorCode::kBadState, which + ": " + started.message);
    }
  }
  if (auto st = store_->resumeRun(run_id); !st.ok) {
    return errorReply(id, ErrorCode::kInternal, st.message);
  }
  if (!done && point.last_imu_t) {
    recordGap(run_id, *point.last_imu_t, *imu_last_t_, "the daemon was down (resume)",
              runner->steps(), restart);
  }
  if (done) {  // every step had finished; only the closing was cut off
    if (auto st = store_->finishRun(run_id, RunState::kFinished, "completed"); !st.ok)
      return errorReply(id, ErrorCode::kInternal, st.message);
    if (calibration) {
      calibration->run_id = run_id;
      startFinalCalibration(*calibration);
    }
    if (hasTemperaturePoints(runner->steps())) startPointCalibrations(run_id);
    return okReply(id, {{"run", run_id}, {"state", "finished"}, {"from_step", next}});
  }
  auto active = std::make_unique<ActiveRun>();
  active->id = run_id;
  active->plan_name = run.start.plan_name;
  active->runner = std::move(runner);
  active->writer = std::make_unique<RunWriter>(*store_, run_id, point);
  active->last_table_t = point.last_table_t;
  active->last_chamber_t = point.last_chamber_t;
  active->last_stored_step = restart.first_void - 1;
  // The plan's calibration goes on too: the final one reads every stored sample (before and
  // after the interruption); the online estimates start again from the resumed step.
  if (calibration) attachCalibration(*active, std::move(*calibration));
  run_ = std::move(active);
  server_->broadcast(Topic::kRun, "resumed", {{"run", run_id}, {"from_step", next}});
  publish(run_->runner->takeEvents());
  log_.info(which + " resumed at step " + std::to_string(next + 1) + "/" +
            std::to_string(run_->runner->steps().size()) + " (plan '" + run_->plan_name + "')");
  return okReply(id, {{"run", run_id},
                      {"state", runnerStateName(run_->runner->state())},
                      {"from_step", next},
                      {"steps", run_->runner->steps().size()}});
}

// The stored segments a gap made void (plan_runner.h GapRestart) are discarded: a temperature
// point's from its chamber step on; a rotation's that lost its hold after only while it is
// still the newest stored (a second resume finds it gone already).
Status BenchDaemon::discardVoidSegments(std::int64_t run_id, const std::vector<RunStep>& steps,
                                        const GapRestart& restart, int last_kept,
                                        bool point_restart) {
  const auto& first = steps[static_cast<std::size_t>(restart.first_void)];
  if (point_restart) {
    return store_->discardSegmentsFrom(run_id, first.label).status;
  }
  std::vector<std::string> labels;
  for (int k = restart.first_void; k <= last_kept; ++k)
    labels.push_back(steps[static_cast<std::size_t>(k)].label);
  return store_->discardTrailingSegments(run_id, labels).status;
}

// A resume's void segments go (resumeAfterGap); point is read again after.
Status BenchDaemon::discardBeforeResume(std::int64_t run_id, const std::vector<RunStep>& steps,
                                        const GapRestart& restart, ResumePoint* point) {
  const int last = point->last_finished_step;
  const bool point_restart = resumeStep(steps, last) <= last;
  if (auto st = discardVoidSegments(run_id, steps, restart, last, point_restart); !st.ok) return st;
  *point = store_->resumePoint(run_id);
  return point->status;
}

// A gap in the run's recording (IMU time from_t to to_t): event "recording_gap" in the run's
// event log, to subscribers and the log, naming where the run goes on and what runs again.
void BenchDaemon::recordGap(std::int64_t run_id, double from_t, double to_t,
                            const std::string& cause, const std::vector<RunStep>& steps,
                            const GapRestart& restart) {
  json fields = {{"run", run_id}, {"from_t", from_t}, {"to_t", to_t}, {"cause", cause}};
  const int n = static_cast<int>(steps.size());
  if (restart.step < n) {
    fields["step"] = restart.step;
    fields["label"] = steps[static_cast<std::size_t>(restart.step)].label;
  }
  // Steps that run again although their segments stored before the gap stay (gapRestart).
  fields["rerun_kept"] = json::array();
  for (int k = restart.step; k < restart.first_void && k < n; ++k)
    fields["rerun_kept"].push_back(steps[static_cast<std::size_t>(k)].label);
  std::ostringstream msg;
  msg << "recording gap from t = " << from_t << " s to t = " << to_t << " s (" << cause
      << "): no segment spans it";
  if (restart.step < n)
    msg << "; the run goes on at step '" << fields["label"].get<std::string>() << "'";
  fields["message"] = msg.str();
  RunEvent stored;
  stored.run_id = run_id;
  stored.wall_unix_s = unixNow();
  stored.severity = EventSeverity::kWarning;
  stored.kind = "recording_gap";
  stored.json = fields.dump();
  if (auto st = store_->addEvent(stored); !st.ok) log_.error("store: " + st.message);
  server_->broadcast(Topic::kRun, "recording_gap", fields);
  log_.warning("run " + std::to_string(run_id) + ": " + msg.str());
}

}  // namespace imubench::daemon
