// BenchDaemon: the plan queue and the remaining commands (status, results, export); the parts
// are listed at the top of daemon/bench_daemon.cpp.

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "daemon/bench_daemon.h"
#include "daemon/bench_daemon_internal.h"

namespace imubench::daemon {

using bench_daemon_internal::errnoWords;
using bench_daemon_internal::loadPlan;
using bench_daemon_internal::unixNow;
using nlohmann::json;

namespace {

namespace fs = std::filesystem;

// The directory exports go to (exports/ next to the database), created 0750 when missing and
// given to the readers' group. Refused when it is anything but a real directory (e.g. a
// symlink planted there).
Status exportRoot(const std::string& db, const std::optional<NamedGroup>& group,
                  std::string* root) {
  std::error_code ec;
  *root = (fs::absolute(fs::path(db), ec).parent_path() / "exports").string();
  if (ec) return Status::Error(db + ": " + ec.message());
  if (::mkdir(root->c_str(), 0750) != 0 && errno != EEXIST)
    return Status::Error(*root + ": cannot create: " + errnoWords(errno));
  struct stat st {};
  if (::lstat(root->c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    return Status::Error(*root + ": not a directory");
  return shareWithGroup(*root, group, 0750);
}

// Writes run `run` of the store at db to exports/<name> next to it (runs off the loop: its own
// store connection). The reply to the export request with id `id`.
Reply exportToStateDir(const std::string& db, std::int64_t run, const std::string& name,
                       const json& id, const std::optional<NamedGroup>& group) {
  std::string root;
  if (auto st = exportRoot(db, group, &root); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  auto opened = Store::open(db, StoreOptions{});
  if (!opened.status.ok) return errorReply(id, ErrorCode::kInternal, opened.status.message);
  auto rec = opened.value->loadRecording(run);
  if (!rec.status.ok) return errorReply(id, ErrorCode::kNotFound, rec.status.message);
  const std::string dir = root + "/" + name;
  if (::mkdir(dir.c_str(), 0750) != 0) {
    const bool exists = errno == EEXIST;
    return errorReply(id, exists ? ErrorCode::kBadArgument : ErrorCode::kInternal,
                      dir + (exists ? ": exists already; name another export directory (dir)"
                                    : ": cannot create: " + errnoWords(errno)));
  }
  if (auto st = io::writeRecording(dir, rec.value); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  if (auto st = shareDirWithGroup(dir, group); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  return okReply(id, toJson(ExportReply{run, dir, rec.value.imu.size()}));
}

}  // namespace

// ---- the plan queue (stored: it survives a restart) -----------------------------------------

// A validated plan appended to the queue; it starts when the runs before it have completed.
Reply BenchDaemon::enqueue(const Request& request, const std::string& name,
                           const LoadedPlan& loaded) {
  QueueEntry entry;
  entry.plan_name = loaded.plan.name;
  entry.source = name;
  entry.plan_toml = loaded.text;
  entry.label = std::get<StartArgs>(request.args).options.label;
  const QueueAddResult added = store_->queueAdd(entry);
  if (!added.status.ok) return errorReply(request.id, ErrorCode::kInternal, added.status.message);
  const QueuedEvent queued{added.value.entry_id, added.value.position, entry.plan_name};
  log_.info("plan '" + entry.plan_name + "' queued: entry " + std::to_string(added.value.entry_id) +
            ", position " + std::to_string(added.value.position));
  server_->broadcast(queued);
  return okReply(request.id, toJson(QueuedReply{queued}));
}

// The queue's head started now (no run going). It leaves the queue only once it has started;
// a plan the bench refuses now stays queued (the reply says why).
Reply BenchDaemon::startQueued(const json& id) {
  if (run_) {
    return errorReply(id, ErrorCode::kBadState,
                      "run " + std::to_string(run_->id) +
                          " is going; the queue goes on by itself when it completes");
  }
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(id, ErrorCode::kInternal, list.status.message);
  if (list.value.empty()) return errorReply(id, ErrorCode::kNotFound, "the queue is empty");
  const QueueEntry& head = list.value.front();
  const std::string which =
      "queue entry " + std::to_string(head.id) + " (plan '" + head.plan_name + "')";
  std::string why;
  const auto loaded = loadPlan(head.source, head.plan_toml, bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, which + ": " + why);
  Reply r = launch(*loaded, id);
  if (!r.ok) {
    r.error.message = which + ": " + r.error.message;
    return r;
  }
  if (auto st = store_->queueRemove(head.id); !st.ok) log_.error("store: " + st.message);
  r.result["entry"] = head.id;  // StartReply::entry
  server_->broadcast(QueueStartedEvent{head.id, run_->id, run_->plan_name});
  log_.info(which + " started as run " + std::to_string(run_->id));
  return r;
}

// After a run completed: the next queued plan, if any. One that cannot start holds the queue.
void BenchDaemon::advanceQueue() {
  if (stopping_ || run_) return;
  const Reply r = startQueued(nullptr);
  if (r.ok || r.error.code == ErrorCode::kNotFound) return;
  log_.warning("queue held: " + r.error.message);
  server_->broadcast(QueueHeldEvent{r.error.message});
}

Reply BenchDaemon::queueReply(const json& id) {
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(id, ErrorCode::kInternal, list.status.message);
  QueueReply reply;
  for (std::size_t i = 0; i < list.value.size(); ++i) {
    const QueueEntry& e = list.value[i];
    reply.queue.push_back(
        {e.id, static_cast<std::int64_t>(i + 1), e.plan_name, e.source, e.label, e.added_unix_s});
  }
  return okReply(id, toJson(reply));
}

// queue_move and queue_remove; the reply is the queue as it is now.
Reply BenchDaemon::queueChange(const Request& request) {
  const bool move = request.command == Command::kQueueMove;
  const std::int64_t entry = move ? std::get<QueueMoveArgs>(request.args).entry
                                  : std::get<QueueRemoveArgs>(request.args).entry;
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(request.id, ErrorCode::kInternal, list.status.message);
  const std::string which = "queue entry " + std::to_string(entry);
  if (std::none_of(list.value.begin(), list.value.end(),
                   [entry](const QueueEntry& e) { return e.id == entry; }))
    return errorReply(request.id, ErrorCode::kNotFound, which + " is not queued");
  Status st;
  if (move) {
    const int position = std::get<QueueMoveArgs>(request.args).position;
    if (static_cast<std::size_t>(position) > list.value.size()) {
      return errorReply(request.id, ErrorCode::kBadArgument,
                        "position: " + std::to_string(position) + " is beyond the queue's " +
                            std::to_string(list.value.size()) + " entries");
    }
    st = store_->queueMove(entry, position);
  } else {
    st = store_->queueRemove(entry);
  }
  if (!st.ok) return errorReply(request.id, ErrorCode::kInternal, st.message);
  log_.info(which + (move ? " moved" : " removed"));
  return queueReply(request.id);
}

Reply BenchDaemon::runnerCommand(const Request& request) {
  const double now = wallNow();
  if (request.command == Command::kStop) {
    // Emergency stop works in every state, with or without a run.
    if (run_) {
      run_->runner->emergencyStop(now, "operator (control socket)");
      publish(run_->runner->takeEvents());
      closeRun();
    } else {
      const Status st = port_->emergencyStop();
      log_.warning("emergency stop (no run)" + (st.ok ? std::string() : ": " + st.message));
    }
    return okReply(request.id, toJson(StopReply{true}));
  }
  if (request.command == Command::kResume) {
    const std::optional<std::int64_t> which = std::get<ResumeArgs>(request.args).run;
    if (which && (!run_ || run_->id != *which)) return resumeInterrupted(request, *which);
  }
  if (!run_) return errorReply(request.id, ErrorCode::kBadState, "no run in progress");
  Status r;
  if (request.command == Command::kPause) r = run_->runner->pause(now);
  if (request.command == Command::kResume) r = run_->runner->resume(now);
  if (request.command == Command::kAbort) r = run_->runner->abort(now);
  publish(run_->runner->takeEvents());
  if (!r.ok) return errorReply(request.id, ErrorCode::kBadState, r.message);
  return okReply(request.id,
                 toJson(RunCommandReply{run_->id, runnerStateName(run_->runner->state())}));
}

// After a controller restart (interlock open, modes lost) the run stays paused until the
// operator re-arms: the same preparation as a start (connect, interlock closed, refused on an
// emergency stop or trip, which are cleared at the controller). Never while the table moves.
Reply BenchDaemon::rearm(const Request& request) {
  if (run_ && run_->runner->state() != RunnerState::kPaused) {
    return errorReply(request.id, ErrorCode::kBadState,
                      std::string("re-arm only with no run or a paused one; the run is ") +
                          runnerStateName(run_->runner->state()) + " (pause it first)");
  }
  const Status st = port_->prepare();
  const std::string who = run_ ? "run " + std::to_string(run_->id) + ": " : std::string();
  if (!st.ok) {
    log_.warning(who + "re-arm refused: " + st.message);
    return errorReply(request.id, ErrorCode::kBadState, "re-arm refused: " + st.message);
  }
  table_answered_s_ = wallNow();  // prepare() read the table
  log_.info(who + "bench re-armed by the operator (interlock closed)");
  if (run_) {
    RunEvent stored;
    stored.run_id = run_->id;
    stored.wall_unix_s = unixNow();
    stored.severity = EventSeverity::kInfo;
    stored.kind = RearmedEvent::kEvent;
    stored.json = toJson(RearmedEvent{run_->id}).dump();
    if (auto added = store_->addEvent(stored); !added.ok) log_.error("store: " + added.message);
    server_->broadcast(RearmedEvent{run_->id});
    onPoll();  // a fresh observation, so a resume right after sees the closed interlock
  }
  return okReply(request.id, toJson(RearmReply{tableStatus()}));
}

// The table as last read: what the operator needs to see to re-arm or clear it.
TableStatus BenchDaemon::tableStatus() const {
  const drivers::TableReading& r = port_->lastReading();
  const char* interlock = r.interlock_tripped ? "tripped" : r.interlock_closed ? "closed" : "open";
  TableStatus t{interlock,    r.estop,      r.fault,     drivers::deviceStateName(table_->state()),
                std::nullopt, std::nullopt, std::nullopt};
  if (!port_->lastTableError().empty()) t.error = port_->lastTableError();
  if (table_answered_s_) t.age_s = wallNow() - *table_answered_s_;
  if (!r.axes.empty()) {  // the last read's axes (none after a read that got no answer)
    std::vector<double> angles;
    bool moving = false;
    for (const drivers::TableAxisReading& a : r.axes) {
      angles.push_back(a.angle * kRadToDeg);
      moving = moving || a.moving;
    }
    t.angles_deg = angles;
    t.moving = moving;
  }
  return t;
}

Reply BenchDaemon::status() const {
  StatusReply s;
  s.bench = bench_.name;
  s.state = run_ ? runnerStateName(run_->runner->state()) : "idle";
  s.imu_time_s = imu_last_t_;
  s.imu_lost_samples = imu_->decoder().counters().lost_samples;
  s.imu_bad_frames = imu_->decoder().counters().badFrames();
  s.imu_restarts = imu_->decoder().counters().restarts;
  s.table = tableStatus();
  s.lab = labStatus();
  if (const auto waiting = store_->queueList(); waiting.status.ok) {
    s.queued = waiting.value.size();  // plans in the queue (queue_list)
  }
  if (run_) {
    const PlanRunner& r = *run_->runner;
    const RunStep& shown = r.displayedStep();
    s.run = run_->id;
    s.plan = run_->plan_name;
    s.progress = run_->shownProgress();
    s.eta_s = r.etaS();
    s.step = StatusStep{shown.index, shown.label, calib::segmentKindName(shown.kind),
                        static_cast<std::int64_t>(r.steps().size())};
  }
  return okReply(nullptr, toJson(s));
}

// The plan library's directory is read off the loop too (it may sit on a network share).
std::optional<Reply> BenchDaemon::listPlans(const Request& request, ClientId client) {
  auto done = [this, client, id = request.id](std::vector<std::string> files) {
    server_->sendReply(client,
                       okReply(id, toJson(PlanListReply{bench_.plan_dir, std::move(files)})));
  };
  std::string why;
  if (!plans_->list(done, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

std::optional<Reply> BenchDaemon::validatePlan(const Request& request, ClientId client) {
  return withPlanText(request, client, std::get<ValidatePlanArgs>(request.args).plan,
                      [this, request](const std::string& name, const std::string& text) {
                        std::string why;
                        const auto loaded = loadPlan(name, text, bench_, &why);
                        if (!loaded) return errorReply(request.id, ErrorCode::kBadPlan, why);
                        const PlanSummary summary{
                            loaded->plan.name,
                            static_cast<std::int64_t>(loaded->motion.segments.size()),
                            loaded->motion.duration};
                        return okReply(request.id, toJson(ValidatePlanReply{summary}));
                      });
}

Reply BenchDaemon::results(const Request& request) {
  const auto& args = std::get<ResultsArgs>(request.args);
  if (!args.run) {
    const auto runs = store_->listRuns();
    if (!runs.status.ok) return errorReply(request.id, ErrorCode::kInternal, runs.status.message);
    RunListReply list;
    for (const RunInfo& r : runs.value) {
      list.runs.push_back(
          {r.id, r.start.plan_name, runStateName(r.state), r.exit_reason, r.started_unix_s});
    }
    return okReply(request.id, toJson(list));
  }
  const auto info = store_->runInfo(*args.run);
  if (!info.status.ok) return errorReply(request.id, ErrorCode::kNotFound, info.status.message);
  ResultFilter filter;
  filter.run_id = *args.run;
  const auto stored = store_->results(filter);
  RunResultsReply reply{*args.run, runStateName(info.value.state), info.value.exit_reason, {}};
  for (const StoredResult& r : stored.value) {
    json doc = json::parse(r.json, nullptr, false);
    if (doc.is_discarded()) doc = nullptr;  // unreadable stored text: null, never invalid JSON
    reply.results.push_back({r.kind, std::move(doc)});
  }
  return okReply(request.id, toJson(reply));
}

// Exports go only to a new directory under exports/ next to the database (the client names
// it, one path component): the daemon never writes where a client points it. Loading a whole
// run and writing it out takes long: it runs off the loop on a second store connection (WAL
// readers do not block the run's writer), and the reply follows.
std::optional<Reply> BenchDaemon::exportRun(const Request& request, ClientId client) {
  const auto& args = std::get<ExportArgs>(request.args);
  if (run_ && run_->id == args.run) run_->writer->flush();  // the export sees what is recorded
  const std::string name = args.dir.empty() ? "run-" + std::to_string(args.run) : args.dir;
  const std::optional<NamedGroup> group =
      fileGroup({bench_.control.command_group, bench_.control.read_group, ::geteuid()});
  auto job = [this, client, db = db_path_, run = args.run, name, id = request.id,
              group]() -> std::function<void()> {
    Reply r = exportToStateDir(db, run, name, id, group);
    return [this, client, r] { server_->sendReply(client, r); };
  };
  auto failed = [this, client, id = request.id](const std::string& what) {
    server_->sendReply(client, errorReply(id, ErrorCode::kInternal, "export failed: " + what));
  };
  std::string why;
  if (!exports_->run(job, failed, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

}  // namespace imubench::daemon
