// imubench start | pause | resume | abort | stop | status | watch | queue: the operator's
// commands to a running imubenchd over its control socket (tools/control_client.h).
//
//   imubench start PLAN [--label L] [--dry-run] [--out-dir DIR] [--watch] [--queue]
//     PLAN is read here, with the operator's rights, and its text sent (the daemon reads no
//     client-named files); diagnostics name PLAN by its path. --queue: while a run is going (or
//     plans wait), the plan is validated and appended to the daemon's plan queue instead.
//   imubench queue [--json]                 the plan queue (position, entry id, plan, label)
//   imubench queue move ENTRY POSITION      reorder (1 = next to start)
//   imubench queue remove ENTRY             take a plan out of the queue
//   imubench queue resume                   start the queue's head now (after an abort, a
//                                           fault or a daemon restart the queue holds)
//   imubench pause | resume | abort | stop          (stop = emergency stop: one line to the
//                                           daemon's stop socket, SOCKET.stop)
//   imubench resume RUN          run RUN, interrupted by a daemon crash, power loss, stop,
//                                abort or fault, goes on from its last finished step
//                                (appending to the run); inside a temperature point: from
//                                the point's chamber step
//   imubench status [--json]     imubench watch [--json]     (results: cli_results.cpp, the store)
// Every command takes --socket PATH (default $IMUBENCH_SOCKET, else /run/imubench/control.sock).
// Human output by default; --json prints the daemon's raw reply (watch: the raw event lines).
// An ok=false reply prints "error (code): message" and exits 1; so does a daemon that cannot
// be reached (naming the socket). watch exits 0 when the run completed, 1 otherwise.
//
// The daemon's replies and events are the typed structs of daemon/control_protocol.h, read with
// its fromJson / parseEvent (the daemon builds them with the same structs): status ->
// StatusReply, start -> StartReply / DryRunReply / QueuedReply, queue commands -> QueueReply,
// pause/resume/abort -> RunCommandReply; the watch fold reads the events RunStateEvent,
// StepStartedEvent, StepFinishedEvent, ProgressEvent, AlarmEvent and RunFinishedEvent. A reply
// that does not read is an error naming the field; an unreadable alarm is still shown.
// results is printed generically (key: value; arrays one element per line). "estimate" and
// "log" events are not part of the protocol yet and are shown as text when they come.
// The run has ended when its state is finished (completed unless "exit" says otherwise),
// faulted, aborted or interrupted. Without a progress figure the percentage is step/count.
#include "tools/cli_control.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "daemon/control_protocol.h"
#include "io/file_io.h"
#include "io/verdict.h"
#include "tools/cli_common.h"
#include "tools/control_client.h"

namespace imubench::tools {

using nlohmann::json;

namespace {

std::string dumpJson(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::optional<double> numField(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  const double v = it->get<double>();
  return std::isfinite(v) ? std::optional<double>(v) : std::nullopt;
}

// A string field; numbers and other scalars are shown as JSON text.
std::optional<std::string> textField(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  if (it->is_string()) return it->get<std::string>();
  return dumpJson(*it);
}

bool isEndState(const std::string& state) {
  return state == "finished" || state == "faulted" || state == "aborted" || state == "interrupted";
}

// A run's state (and exit), unless the run has ended already: an end state sticks.
void applyState(WatchState& s, const std::string& state, const std::optional<std::string>& exit) {
  if (s.ended()) return;
  s.state = state;
  if (exit) s.exit = *exit;
}

// Another run: what was shown of the previous one goes.
void switchRun(WatchState& s, long long run) {
  if (s.run && *s.run != run) s.progress.reset();
  s.run = run;
}

// The bar never goes back within a run: a step re-run after a pause, or a step count figure
// after a planned-time one, would otherwise show 61 % -> 60 %.
void showProgress(WatchState& s, double p) {
  p = std::clamp(p, 0.0, 1.0);
  s.progress = s.progress ? std::max(*s.progress, p) : p;
}

void applyStep(WatchState& s, const daemon::StepRef& at) {
  switchRun(s, at.run);
  s.step = at.step;
  s.label = at.label;
}

std::string formatNumber(double v) {
  std::ostringstream o;
  o.precision(6);
  o << v;
  return o.str();
}

}  // namespace

bool WatchState::ended() const {
  return isEndState(state);
}

bool WatchState::completed() const {
  return state == "finished" && (exit.empty() || exit == "completed");
}

void applyStatus(WatchState& s, const json& result) {
  const auto st = daemon::fromJson<daemon::StatusReply>(result, nullptr);
  if (!st) return;  // not a status reply: nothing to fold
  applyState(s, st->state, std::nullopt);
  if (st->run) switchRun(s, *st->run);
  if (st->plan) s.plan = *st->plan;
  if (st->progress) showProgress(s, *st->progress);
  if (st->eta_s) s.eta_s = std::max(*st->eta_s, 0.0);
  if (st->step) {
    s.step = st->step->index;
    s.count = st->step->count;
    s.label = st->step->label;
  }
}

namespace {

// The run events that move the bar; false when name is none of them.
bool applyRunEvent(WatchState& s, const std::string& name, const json& event) {
  using namespace daemon;
  if (name == RunStateEvent::kEvent) {
    if (auto e = parseEvent<RunStateEvent>(event, nullptr)) {
      applyStep(s, e->at);
      applyState(s, e->state, e->exit);
    }
  } else if (name == StepStartedEvent::kEvent) {
    if (auto e = parseEvent<StepStartedEvent>(event, nullptr)) applyStep(s, e->at);
  } else if (name == StepFinishedEvent::kEvent) {
    if (auto e = parseEvent<StepFinishedEvent>(event, nullptr)) {
      applyStep(s, e->at);
      // The steps done so far (indices are 0-based) until the next progress event.
      if (s.count && *s.count > 0) {
        showProgress(s, static_cast<double>(e->at.step + 1) / static_cast<double>(*s.count));
      }
    }
  } else if (name == ProgressEvent::kEvent) {
    if (auto e = parseEvent<ProgressEvent>(event, nullptr)) {
      switchRun(s, e->run);
      applyState(s, e->state, std::nullopt);
      showProgress(s, e->progress);
      s.eta_s = std::max(e->eta_s, 0.0);
      s.step = e->step;
      s.label = e->label;
    }
  } else if (name == RunFinishedEvent::kEvent) {
    if (auto e = parseEvent<RunFinishedEvent>(event, nullptr)) {
      switchRun(s, e->run);
      applyState(s, e->state, e->exit);
    }
  } else {
    return false;
  }
  return true;
}

// The follow-up experiment's events (daemon/follow_up.h): the proposal stored at a plan's end,
// and the joint verdict after the follow-up run. False: not one of them.
bool followUpNote(const std::string& name, const json& event, std::vector<std::string>* notes) {
  if (name != "follow_up" && name != "follow_up_verdict") return false;
  const std::string run =
      event.contains("run") && event["run"].is_number_integer() ? event["run"].dump() : "?";
  const std::string summary = textField(event, "summary").value_or("?");
  if (name == "follow_up") {
    notes->push_back("run " + run + ": " + summary +
                     (textField(event, "status").value_or("") == "proposed"
                          ? " (imubench results " + run + "; imubench queue accept " + run + ")"
                          : ""));
    return true;
  }
  const std::string origin = event.contains("origin_run") ? event["origin_run"].dump() : "?";
  notes->push_back("run " + run + " (follow-up of run " + origin + "): " +
                   (event.value("ok", false) ? summary : "joint analysis failed: " + summary));
  return true;
}

}  // namespace

void applyEvent(WatchState& s, const json& event, std::vector<std::string>* notes) {
  if (!event.is_object() || !event.contains("event") || !event["event"].is_string()) return;
  const std::string name = event["event"].get<std::string>();
  if (applyRunEvent(s, name, event)) return;
  if (notes == nullptr || followUpNote(name, event, notes)) return;
  if (name == daemon::AlarmEvent::kEvent) {
    std::string why;
    const auto e = daemon::parseEvent<daemon::AlarmEvent>(event, &why);
    notes->push_back("ALARM: " + (e ? e->message : "(unreadable: " + why + ")"));
  } else if (name == daemon::SoakEvent::kTimeout || name == daemon::SoakEvent::kSettled) {
    // An auto soak's end (daemon/plan_runner.h); a timeout flags the temperature point.
    const std::string text = textField(event, "message").value_or(name);
    notes->push_back(name == daemon::SoakEvent::kTimeout ? "FLAG: " + text : text);
  } else if (name == "estimate" && event.contains("summary")) {
    // The daemon's online engine: what the steps so far determine (daemon/online_engine.h).
    notes->push_back("estimate after " + textField(event, "summary").value_or("?"));
  } else if (name == "results") {
    const bool has_run = event.contains("run") && event["run"].is_number_integer();
    std::string line =
        "results of run " + (has_run ? std::to_string(event["run"].get<std::int64_t>()) : "?");
    line += event.value("calibrated", false) ? ": calibrated, " + io::verdictWord(event)
                                             : ": calibration failed";
    notes->push_back(line + " (imubench results RUN)");
    // The end-of-plan missing-physics analysis (daemon/run_explain.h): its one-line summary,
    // or why it did not run.
    if (auto ex = textField(event, "explain"); ex && !ex->empty()) {
      notes->push_back("missing physics: " + *ex);
    }
  } else if (name == "estimate") {
    std::string line = "estimate " + textField(event, "parameter").value_or("?");
    if (auto v = numField(event, "value")) line += " = " + formatNumber(*v);
    if (auto sg = numField(event, "sigma")) line += " +/- " + formatNumber(*sg);
    if (auto u = textField(event, "unit")) line += " " + *u;
    notes->push_back(line);
  } else if (name == "log") {
    notes->push_back("log: " + textField(event, "message").value_or(dumpJson(event)));
  }
}

std::string formatDuration(double seconds) {
  const long long t = std::llround(std::max(seconds, 0.0));
  char buf[32];
  if (t >= 3600) {
    std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", t / 3600, (t / 60) % 60, t % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%lld:%02lld", t / 60, t % 60);
  }
  return buf;
}

std::string formatProgressLine(const WatchState& s, int width) {
  std::optional<double> fraction = s.progress;
  if (!fraction && s.step && s.count && *s.count > 0) {
    fraction = std::clamp(static_cast<double>(*s.step) / static_cast<double>(*s.count), 0.0, 1.0);
  }
  if (s.completed()) fraction = 1.0;
  constexpr int kBar = 20;
  std::string line = "[";
  const int filled = fraction ? static_cast<int>(std::floor(*fraction * kBar + 1e-9)) : 0;
  line += std::string(static_cast<std::size_t>(filled), '#');
  line += std::string(static_cast<std::size_t>(kBar - filled), '.');
  line += "] ";
  char pct[16];
  if (fraction) {
    std::snprintf(pct, sizeof pct, "%3d%%", static_cast<int>(std::floor(*fraction * 100 + 1e-9)));
  } else {
    std::snprintf(pct, sizeof pct, " --%%");
  }
  line += pct;
  if (s.eta_s && !s.ended()) line += "  ETA " + formatDuration(*s.eta_s);
  if (s.step) {
    line += "  step " + std::to_string(*s.step);
    if (s.count) line += "/" + std::to_string(*s.count);
  }
  if (!s.label.empty()) line += (s.step ? " " : "  ") + s.label;
  line += "  " + (s.state.empty() ? std::string("?") : s.state);
  if (!s.exit.empty() && s.state == "finished") line += " (" + s.exit + ")";
  if (width > 0 && line.size() > static_cast<std::size_t>(width)) {
    std::size_t cut = static_cast<std::size_t>(width);
    // Never cut a UTF-8 sequence in two.
    while (cut > 0 && (static_cast<unsigned char>(line[cut]) & 0xC0) == 0x80) --cut;
    line.resize(cut);
  }
  return line;
}

std::string formatEndLine(const WatchState& s) {
  std::string line = s.run ? "run " + std::to_string(*s.run) : std::string("run");
  if (s.completed()) return line + " completed";
  if (s.state == "finished") return line + " finished: " + s.exit;
  return line + " " + (s.state.empty() ? std::string("ended") : s.state);
}

namespace {

struct ControlOptions {
  std::string socket = defaultControlSocket();
  bool json = false;
};

void addControlOptions(CLI::App& sub, ControlOptions* o, bool with_json = true) {
  sub.add_option("--socket", o->socket, "imubenchd's control socket ($IMUBENCH_SOCKET overrides)")
      ->capture_default_str();
  if (with_json) sub.add_flag("--json", o->json, "print the daemon's raw reply (JSON)");
}

// Runs fn with a client connected to o.socket; client failures become CommandFailed.
template <typename F>
void withClient(const ControlOptions& o, F fn) {
  try {
    ControlClient c;
    c.connect(o.socket);
    fn(c);
  } catch (const ControlError& e) {
    throw CommandFailed(e.what());
  }
}

// One request; prints the raw reply with --json; an ok=false reply fails the command.
json exchange(const ControlOptions& o, ControlClient& c, json req) {
  const json reply = c.request(std::move(req));
  if (o.json) std::cout << dumpJson(reply) << "\n" << std::flush;
  if (!reply["ok"].get<bool>()) {
    const json& e = reply["error"];
    const std::string code = e.value("code", std::string("?"));
    const std::string message = e.value("message", dumpJson(e));
    throw CommandFailed("error (" + code + "): " + message);
  }
  return reply.contains("result") ? reply["result"] : json::object();
}

// A reply's result as the protocol's struct R; one that does not read fails the command.
template <class R>
R readReply(const json& result, const char* cmd) {
  std::string why;
  auto r = daemon::fromJson<R>(result, &why);
  if (!r) throw CommandFailed(std::string("imubenchd's reply to ") + cmd + ": " + why);
  return std::move(*r);
}

// A result the CLI has no special layout for: "key: value" lines; arrays one element a line.
void printGeneric(const json& j, const std::string& indent = "") {
  if (!j.is_object()) {
    std::cout << indent << dumpJson(j) << "\n";
    return;
  }
  for (const auto& [key, value] : j.items()) {
    if (value.is_array()) {
      std::cout << indent << key << ": " << (value.empty() ? "(none)" : "") << "\n";
      for (const json& el : value) {
        std::string row;
        if (el.is_object()) {
          for (const auto& [k, v] : el.items()) {
            row += (row.empty() ? "" : "  ") + k + "=" +
                   (v.is_string() ? v.get<std::string>() : dumpJson(v));
          }
        } else {
          row = el.is_string() ? el.get<std::string>() : dumpJson(el);
        }
        std::cout << indent << "  " << row << "\n";
      }
    } else if (value.is_object()) {
      std::cout << indent << key << ":\n";
      printGeneric(value, indent + "  ");
    } else {
      std::cout << indent << key << ": "
                << (value.is_string() ? value.get<std::string>() : dumpJson(value)) << "\n";
    }
  }
}

void printStatus(const json& r) {
  const auto st = readReply<daemon::StatusReply>(r, "status");
  WatchState s;
  applyStatus(s, r);
  std::cout << "state: " << st.state << "\n";
  if (st.run) std::cout << "run " << *st.run << ", plan " << st.plan.value_or("?") << "\n";
  if (st.step) {
    std::cout << "step " << st.step->index << "/" << st.step->count << " (" << st.step->kind << ")";
    if (!st.step->label.empty()) std::cout << ": " << st.step->label;
    std::cout << "\n";
  }
  if (st.progress || st.eta_s) std::cout << formatProgressLine(s, 0) << "\n";
  if (st.queued) std::cout << "queued plans: " << *st.queued << "\n";
  const daemon::TableStatus& t = st.table;
  std::cout << "bench " << st.bench << ": table " << t.state << ", interlock " << t.interlock
            << (t.estop ? ", EMERGENCY STOP" : "") << (t.fault ? ", FAULT" : "");
  if (t.error) std::cout << " (" << *t.error << ")";
  std::cout << "\nimu: ";
  if (st.imu_time_s) std::cout << "t " << formatNumber(*st.imu_time_s) << " s, ";
  std::cout << "lost samples " << st.imu_lost_samples << ", bad frames " << st.imu_bad_frames
            << ", restarts " << st.imu_restarts << "\n";
  if (st.lab) {
    std::cout << "lab mirror: " << st.lab->state;
    if (st.lab->state == "fault")
      std::cout << " (" << st.lab->fault << ": " << st.lab->message << ")";
    std::cout << ", outbox "
              << (st.lab->backlog < 0 ? std::string("?") : std::to_string(st.lab->backlog))
              << " waiting, " << st.lab->shipped << " shipped";
    if (st.lab->samples_backlog) {
      std::cout << "; samples "
                << (*st.lab->samples_backlog < 0 ? std::string("?")
                                                 : std::to_string(*st.lab->samples_backlog))
                << " waiting, " << st.lab->samples_shipped.value_or(0) << " shipped";
    }
    std::cout << "\n";
  }
}

int terminalWidth() {
  winsize ws{};
  if (::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 80;
}

// Follows the run until it ends (events of the subscribed connection c, s seeded from a status
// reply). TTY: the bar redrawn in place, notes above it; otherwise one line per event.
void followRun(ControlClient& c, WatchState s, bool json_out) {
  const bool tty = !json_out && ::isatty(STDOUT_FILENO) == 1;
  const int width = tty ? terminalWidth() - 1 : 0;
  auto draw = [&] {
    if (json_out) return;
    if (tty) {
      std::cout << "\r\x1b[K" << formatProgressLine(s, width) << std::flush;
    } else {
      std::cout << formatProgressLine(s, 0) << "\n" << std::flush;
    }
  };
  if (!json_out && s.state == "idle") std::cout << "idle: waiting for a run to start\n";
  draw();
  while (!s.ended()) {
    std::optional<json> ev;
    try {
      ev = c.nextEvent(-1);
    } catch (const ControlError& e) {
      if (tty) std::cout << "\n";
      throw CommandFailed(std::string("watch: ") + e.what());
    }
    if (!ev) continue;
    if (json_out) std::cout << dumpJson(*ev) << "\n" << std::flush;
    std::vector<std::string> notes;
    applyEvent(s, *ev, &notes);
    if (json_out) continue;
    for (const std::string& n : notes) std::cout << (tty ? "\r\x1b[K" : "") << n << "\n";
    if (notes.empty() || tty) draw();
  }
  if (tty) std::cout << "\n";
  if (!json_out) std::cout << formatEndLine(s) << "\n" << std::flush;
  if (!s.completed()) throw CommandFailed(formatEndLine(s) + " (not completed)");
}

void subscribeForWatch(ControlClient& c, const ControlOptions& o) {
  ControlOptions quiet = o;
  quiet.json = false;
  exchange(quiet, c, {{"cmd", "subscribe"}, {"topics", {"run", "status"}}});
}

// ---- start ----
// The daemon's default max_line_bytes (daemon/control_server.h): a longer request is refused.
constexpr std::size_t kMaxRequestBytes = std::size_t{64} * 1024;

// The plan file's text, read with the operator's rights: regular files only (a FIFO or device
// would hang the command), bounded by what one request can carry.
std::string readPlanText(const std::string& path) {
  io::UserFile f = io::readUserFile(path, kMaxRequestBytes, "a control request carries");
  if (f.error == io::UserFileError::kMissing) throw CommandFailed(path + ": no such plan file");
  if (!f.ok()) throw CommandFailed(f.message);
  return std::move(f.text);
}

void printQueued(const daemon::QueuedEvent& q) {
  std::cout << "queued as entry " << q.entry << " at position " << q.position << " (plan " << q.plan
            << ")";
  std::cout << "; it starts when the runs before it have completed\n";
}

struct StartOptions {
  ControlOptions ctl;
  std::string plan;
  std::string label;
  std::string out_dir;
  bool dry_run = false;
  bool watch = false;
  bool queue = false;
};

void runStart(const StartOptions& o) {
  std::error_code ec;
  const std::filesystem::path plan = std::filesystem::absolute(o.plan, ec).lexically_normal();
  if (ec) throw CommandFailed(o.plan + ": " + ec.message());
  json req = {{"cmd", "start"},
              {"plan", {{"toml", readPlanText(plan.string())}, {"name", plan.string()}}}};
  json options = json::object();
  if (o.dry_run) options["dry_run"] = true;
  if (o.queue) options["queue"] = true;
  if (!o.label.empty()) options["label"] = o.label;
  if (!o.out_dir.empty()) {
    options["out_dir"] = std::filesystem::absolute(o.out_dir).lexically_normal().string();
  }
  if (!options.empty()) req["options"] = options;
  withClient(o.ctl, [&](ControlClient& c) {
    if (o.watch) subscribeForWatch(c, o.ctl);  // before start: no event of the run is missed
    const json r = exchange(o.ctl, c, req);
    if (r.contains("queued")) {
      const auto q = readReply<daemon::QueuedReply>(r, "start");
      if (!o.ctl.json) printQueued(q.queued);
      return;  // a queued plan has no run to watch yet
    }
    if (o.dry_run) {
      const auto d = readReply<daemon::DryRunReply>(r, "start");
      if (!o.ctl.json) {
        std::cout << "dry run: " << plan.string() << " accepted: plan " << d.summary.plan << ", "
                  << d.summary.steps << " steps, " << formatDuration(d.summary.planned_s)
                  << " planned\n";
      }
      return;
    }
    const auto started = readReply<daemon::StartReply>(r, "start");
    if (!o.ctl.json) {
      std::cout << "started run " << started.run << " (plan " << started.summary.plan << ")";
      if (!o.label.empty()) std::cout << " label \"" << o.label << "\"";
      std::cout << ": " << started.summary.steps << " steps, "
                << formatDuration(started.summary.planned_s) << " planned\n";
    }
    if (!o.watch) return;
    WatchState s;
    s.run = started.run;
    s.plan = started.summary.plan;
    applyStatus(s, exchange(ControlOptions{o.ctl.socket, false}, c, {{"cmd", "status"}}));
    followRun(c, s, o.ctl.json);
  });
}

// ---- the plan queue ----
void printQueue(const json& r) {
  const auto q = readReply<daemon::QueueReply>(r, "queue");
  if (q.queue.empty()) {
    std::cout << "the queue is empty\n";
    return;
  }
  std::cout << "pos  entry  plan  (file)  label\n";
  for (const daemon::QueueListEntry& e : q.queue) {
    std::cout << e.position << "  " << e.entry << "  " << e.plan << "  (" << e.name << ")";
    if (!e.label.empty()) std::cout << "  \"" << e.label << "\"";
    std::cout << "\n";
  }
}

struct QueueOptions {
  ControlOptions ctl;
  long long entry = 0;
  long long position = 0;
};

// queue_list, or a change (queue_move, queue_remove) whose reply is the queue as it is now.
void runQueue(const QueueOptions& o, const std::string& cmd) {
  json req = {{"cmd", cmd}};
  if (cmd == "queue_move" || cmd == "queue_remove") req["entry"] = o.entry;
  if (cmd == "queue_move") req["position"] = o.position;
  withClient(o.ctl, [&](ControlClient& c) {
    const json r = exchange(o.ctl, c, req);
    if (!o.ctl.json) printQueue(r);
  });
}

void addQueueCommands(CLI::App& app, const std::string& group) {
  auto o = std::make_shared<QueueOptions>();
  CLI::App* q = app.add_subcommand(
      "queue", "the plan queue: list it (no subcommand), move, remove, resume, accept");
  q->group(group);
  q->require_subcommand(0, 1);
  q->fallthrough();  // --socket/--json also after move/remove/resume/accept
  addControlOptions(*q, &o->ctl);
  CLI::App* move = q->add_subcommand("move", "move a queued plan to POSITION (1 = next)");
  move->add_option("ENTRY", o->entry, "queue entry id")->required()->check(CLI::PositiveNumber);
  move->add_option("POSITION", o->position, "new position")->required()->check(CLI::PositiveNumber);
  move->callback([o] { runQueue(*o, "queue_move"); });
  CLI::App* remove = q->add_subcommand("remove", "take a plan out of the queue");
  remove->add_option("ENTRY", o->entry, "queue entry id")->required()->check(CLI::PositiveNumber);
  remove->callback([o] { runQueue(*o, "queue_remove"); });
  CLI::App* resume = q->add_subcommand(
      "resume", "start the queue's head now (no run going; after an abort or a restart)");
  resume->callback([o] {
    withClient(o->ctl, [&](ControlClient& c) {
      const auto r =
          readReply<daemon::StartReply>(exchange(o->ctl, c, {{"cmd", "queue_resume"}}), "queue");
      if (o->ctl.json) return;
      std::cout << "started queue entry " << (r.entry ? std::to_string(*r.entry) : "?")
                << " as run " << r.run << " (plan " << r.summary.plan << ")\n";
    });
  });
  CLI::App* accept = q->add_subcommand(
      "accept", "queue the follow-up plan explain proposed at RUN's end (imubench results RUN)");
  accept->add_option("RUN", o->entry, "run id")->required()->check(CLI::PositiveNumber);
  accept->callback([o] {
    withClient(o->ctl, [&](ControlClient& c) {
      const auto r = readReply<daemon::QueuedReply>(
          exchange(o->ctl, c, {{"cmd", "queue_accept"}, {"run", o->entry}}), "queue accept");
      if (!o->ctl.json) printQueued(r.queued);
    });
  });
  q->callback([o, q] {
    if (q->get_subcommands().empty()) runQueue(*o, "queue_list");
  });
}

// ---- stop: one line to the daemon's stop socket ----
// The emergency stop goes to the stop socket (served before anything else the daemon does,
// never full): one connect, one line, one reply. A daemon without one (older, or the path
// does not exist) gets it on the control socket.
// `imubench stop` without --json is served by the front end (tools/imubench_front.cpp) with the
// same sendEmergencyStop, messages and exit codes, so an operator's stop does not wait for this
// program's libraries to load.
void runStop(const ControlOptions& o, const std::string& stop_socket) {
  try {
    const json reply = sendEmergencyStop(o.socket, stop_socket);
    if (o.json) std::cout << dumpJson(reply) << "\n" << std::flush;
    throwIfRefused(reply);
  } catch (const ControlError& e) {
    throw CommandFailed(e.what());
  }
  if (!o.json) std::cout << kEmergencyStopSent << "\n";
}

// ---- pause / resume / abort ----
void runSimple(const ControlOptions& o, const std::string& cmd, const std::string& done) {
  withClient(o, [&](ControlClient& c) {
    const json r = exchange(o, c, {{"cmd", cmd}});
    if (o.json) return;
    std::cout << done;
    if (cmd == "pause" || cmd == "resume" || cmd == "abort") {
      const auto rc = readReply<daemon::RunCommandReply>(r, cmd.c_str());
      std::cout << " (run " << rc.run << ", state " << rc.state << ")";
    } else if (cmd == "rearm") {
      std::cout << " (interlock " << readReply<daemon::RearmReply>(r, "rearm").table.interlock
                << ")";
    }
    std::cout << "\n";
  });
}

// ---- resume: the paused run, or an interrupted one by id ----
void runResume(const ControlOptions& o, std::optional<long long> run) {
  json req = {{"cmd", "resume"}};
  if (run) req["run"] = *run;
  withClient(o, [&](ControlClient& c) {
    const json r = exchange(o, c, req);
    if (o.json) return;
    std::cout << (run ? "run " + std::to_string(*run) + " resumed" : std::string("resumed"));
    if (const auto step = r.find("from_step"); step != r.end() && step->is_number_integer()) {
      std::cout << " at step " << step->get<long long>() + 1;
    }
    if (auto st = textField(r, "state")) std::cout << " (state " << *st << ")";
    std::cout << "\n";
  });
}

}  // namespace

void addControlCommands(CLI::App& app) {
  const std::string group = "Daemon control";
  {
    auto o = std::make_shared<StartOptions>();
    CLI::App* sub = app.add_subcommand("start", "start a plan on the bench (imubenchd)");
    sub->group(group);
    sub->add_option("PLAN", o->plan, "plan file (TOML), read here and sent as text")->required();
    sub->add_option("--label", o->label, "free text stored with the run");
    sub->add_option("--out-dir", o->out_dir, "where the daemon writes the recording");
    CLI::Option* dry = sub->add_flag("--dry-run", o->dry_run, "validate and expand, move nothing");
    CLI::Option* watch =
        sub->add_flag("--watch", o->watch, "follow the run until it ends (as `imubench watch`)")
            ->excludes(dry);
    sub->add_flag("--queue", o->queue,
                  "while a run is going (or plans wait): validate the plan and append it to "
                  "the daemon's plan queue; it starts when the runs before it completed")
        ->excludes(dry)
        ->excludes(watch);
    addControlOptions(*sub, &o->ctl);
    sub->callback([o] { runStart(*o); });
  }
  struct Simple {
    const char* name;
    const char* help;
    const char* done;
  };
  for (const Simple& s :
       {Simple{"pause", "hold the run at the next safe point", "pause requested"},
        Simple{"abort", "stop the run in an orderly way", "abort requested"},
        Simple{"rearm",
               "close the table's interlock again after a controller restart (no run or a "
               "paused one; then resume)",
               "re-armed"}}) {
    auto o = std::make_shared<ControlOptions>();
    CLI::App* sub = app.add_subcommand(s.name, s.help);
    sub->group(group);
    addControlOptions(*sub, o.get());
    const std::string cmd = s.name;
    const std::string done = s.done;
    sub->callback([o, cmd, done] { runSimple(*o, cmd, done); });
  }
  {
    auto o = std::make_shared<ControlOptions>();
    auto stop_socket = std::make_shared<std::string>();
    CLI::App* sub = app.add_subcommand(
        "stop",
        "EMERGENCY STOP: halt all motion now (sent to the daemon's stop socket, which is never "
        "full and is served before anything else)");
    sub->group(group);
    addControlOptions(*sub, o.get());
    sub->add_option("--stop-socket", *stop_socket,
                    "the daemon's stop socket (default: the control socket's path + \".stop\"; "
                    "when that does not exist, the control socket; the bench file's [control] "
                    "stop_socket when it names another)");
    sub->callback([o, stop_socket] { runStop(*o, *stop_socket); });
  }
  {
    auto o = std::make_shared<ControlOptions>();
    auto run = std::make_shared<std::optional<long long>>();
    CLI::App* sub = app.add_subcommand(
        "resume",
        "continue the paused run; with RUN: continue run RUN, interrupted by a daemon crash, "
        "power loss, stop, abort or fault, from its last finished step (inside a temperature "
        "point: from the point's chamber step)");
    sub->group(group);
    sub->add_option("RUN", *run,
                    "an interrupted, aborted or faulted run's id (imubench runs lists them)")
        ->check(CLI::PositiveNumber);
    addControlOptions(*sub, o.get());
    sub->callback([o, run] { runResume(*o, *run); });
  }
  {
    auto o = std::make_shared<ControlOptions>();
    CLI::App* sub = app.add_subcommand("status", "the daemon's current state and run");
    sub->group(group);
    addControlOptions(*sub, o.get());
    sub->callback([o] {
      withClient(*o, [&](ControlClient& c) {
        const json r = exchange(*o, c, {{"cmd", "status"}});
        if (!o->json) printStatus(r);
      });
    });
  }
  addQueueCommands(app, group);
  {
    auto o = std::make_shared<ControlOptions>();
    CLI::App* sub = app.add_subcommand(
        "watch", "follow the run: progress, ETA, step and state; exit 0 when it completed");
    sub->group(group);
    sub->add_option("--socket", o->socket,
                    "imubenchd's control socket ($IMUBENCH_SOCKET overrides)")
        ->capture_default_str();
    sub->add_flag("--json", o->json, "print the status reply and every event as raw JSON lines");
    sub->callback([o] {
      withClient(*o, [&](ControlClient& c) {
        subscribeForWatch(c, *o);
        WatchState s;
        applyStatus(s, exchange(*o, c, {{"cmd", "status"}}));
        followRun(c, s, o->json);
      });
    });
  }
}

}  // namespace imubench::tools
