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
//   imubench pause | resume | abort | stop          (stop = emergency stop)
//   imubench status [--json]     imubench watch [--json]     (results: cli_results.cpp, the store)
// Every command takes --socket PATH (default $IMUBENCH_SOCKET, else /run/imubench/control.sock).
// Human output by default; --json prints the daemon's raw reply (watch: the raw event lines).
// An ok=false reply prints "error (code): message" and exits 1; so does a daemon that cannot
// be reached (naming the socket). watch exits 0 when the run completed, 1 otherwise.
//
// ASSUMED daemon fields (the protocol fixes requests and the reply/event envelope, not yet
// what status and the run events carry). Everything is optional: what is missing is not shown.
//   status result: {"state":"running","run":12,"plan":"name",
//                   "step":{"index":3,"count":45,"label":"..."},"progress":0.31,"eta_s":812.5}
//                  (a finished run may add "exit":"completed"|"aborted"|"emergency_stop", the
//                  RunExit names of daemon/plan_runner.h; "step" may also be a bare index)
//   start result:  {"run":12,"plan":"name"} (anything else is printed as key: value)
//   results:       printed generically (key: value; arrays one element per line)
//   events, topic "run":
//     {"event":"state","state":"paused"}  (finished runs: + "exit"; states are the
//                                            RunnerState names: idle running paused aborting
//                                            finished faulted)
//     {"event":"step_started","step":3,"label":"..."}   {"event":"step_finished","step":3,...}
//     {"event":"alarm","message":"..."}
//   events, topic "status":
//     {"event":"progress","progress":0.31,"eta_s":812.5,"step":3,"label":"..."}
//     {"event":"estimate","parameter":"gyro.bias.x","value":1.2e-5,"sigma":3e-7[,"unit":".."]}
//     {"event":"status",...}  (a periodic snapshot shaped like the status result)
// The run has ended when its state is finished (completed unless "exit" says otherwise),
// faulted, aborted or interrupted. Without "progress" the percentage is step/count.
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

#include "io/file_io.h"
#include "tools/cli_common.h"
#include "tools/control_client.h"

namespace imubench::tools {

using nlohmann::json;

namespace {

std::string dumpJson(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::optional<long long> intField(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  if (it->is_number_float()) return static_cast<long long>(std::llround(it->get<double>()));
  return it->get<long long>();
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

// The fields status results, progress and status events share.
void applyCommon(WatchState& s, const json& j) {
  if (!j.is_object()) return;
  if (!s.ended()) {
    if (auto v = textField(j, "state")) s.state = *v;
    if (auto v = textField(j, "exit")) s.exit = *v;
  }
  if (auto v = intField(j, "run")) s.run = v;
  if (auto v = textField(j, "plan")) s.plan = *v;
  if (auto v = numField(j, "progress")) s.progress = std::clamp(*v, 0.0, 1.0);
  if (auto v = numField(j, "eta_s")) s.eta_s = std::max(*v, 0.0);
  if (auto v = textField(j, "label")) s.label = *v;
  if (auto v = intField(j, "count")) s.count = v;
  const auto step = j.find("step");
  if (step != j.end() && step->is_object()) {
    if (auto v = intField(*step, "index")) s.step = v;
    if (auto v = intField(*step, "count")) s.count = v;
    if (auto v = textField(*step, "label")) s.label = *v;
  } else if (auto v = intField(j, "step")) {
    s.step = v;
  }
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
  applyCommon(s, result);
}

void applyEvent(WatchState& s, const json& event, std::vector<std::string>* notes) {
  if (!event.is_object() || !event.contains("event") || !event["event"].is_string()) return;
  const std::string name = event["event"].get<std::string>();
  if (name == "state" || name == "progress" || name == "status" || name == "step_started" ||
      name == "step_finished") {
    applyCommon(s, event);
    if (name == "step_finished" && !event.contains("progress") && s.step && s.count &&
        *s.count > 0) {
      // Without a progress field: the steps done so far (indices taken as 0-based).
      s.progress =
          std::clamp(static_cast<double>(*s.step + 1) / static_cast<double>(*s.count), 0.0, 1.0);
    }
    return;
  }
  if (notes == nullptr) return;
  if (name == "alarm") {
    std::string line = "ALARM";
    if (auto step = intField(event, "step")) line += " at step " + std::to_string(*step);
    line += ": " + textField(event, "message").value_or("(no message)");
    notes->push_back(line);
  } else if (name == "estimate" && event.contains("summary")) {
    // The daemon's online engine: what the steps so far determine (daemon/online_engine.h).
    notes->push_back("estimate after " + textField(event, "summary").value_or("?"));
  } else if (name == "results") {
    std::string line = "results of run " + std::to_string(intField(event, "run").value_or(-1));
    const bool pass =
        event.contains("pass") && event["pass"].is_boolean() && event["pass"].get<bool>();
    line += event.value("calibrated", false) ? (pass ? ": calibrated, PASS" : ": calibrated, FAIL")
                                             : ": calibration failed";
    notes->push_back(line + " (imubench results RUN)");
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
  WatchState s;
  applyStatus(s, r);
  std::cout << "state: " << (s.state.empty() ? "?" : s.state);
  if (!s.exit.empty()) std::cout << " (" << s.exit << ")";
  std::cout << "\n";
  if (s.run || !s.plan.empty()) {
    std::cout << (s.run ? "run " + std::to_string(*s.run) : std::string("run"));
    if (!s.plan.empty()) std::cout << ", plan " << s.plan;
    std::cout << "\n";
  }
  if (s.step) {
    std::cout << "step " << *s.step;
    if (s.count) std::cout << "/" << *s.count;
    if (!s.label.empty()) std::cout << ": " << s.label;
    std::cout << "\n";
  }
  if (s.progress || s.eta_s) {
    std::cout << formatProgressLine(s, 0) << "\n";
  }
  // What this CLI does not know yet is still shown.
  json rest = r.is_object() ? r : json::object();
  for (const char* k : {"state", "exit", "run", "plan", "step", "progress", "eta_s", "label"}) {
    rest.erase(k);
  }
  printGeneric(rest);
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
constexpr std::size_t kMaxRequestBytes = 64 * 1024;

// The plan file's text, read with the operator's rights: regular files only (a FIFO or device
// would hang the command), bounded by what one request can carry.
std::string readPlanText(const std::string& path) {
  io::UserFile f = io::readUserFile(path, kMaxRequestBytes, "a control request carries");
  if (f.error == io::UserFileError::kMissing) throw CommandFailed(path + ": no such plan file");
  if (!f.ok()) throw CommandFailed(f.message);
  return std::move(f.text);
}

void printQueued(const json& q) {
  std::cout << "queued as entry " << textField(q, "entry").value_or("?") << " at position "
            << textField(q, "position").value_or("?");
  if (auto plan = textField(q, "plan")) std::cout << " (plan " << *plan << ")";
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
      if (!o.ctl.json) printQueued(r["queued"]);
      return;  // a queued plan has no run to watch yet
    }
    if (!o.ctl.json) {
      WatchState s;
      applyStatus(s, r);
      if (o.dry_run) {
        std::cout << "dry run: " << plan.string() << " accepted\n";
      } else {
        std::cout << "started " << (s.run ? "run " + std::to_string(*s.run) : std::string("run"));
        if (!s.plan.empty()) std::cout << " (plan " << s.plan << ")";
        if (!o.label.empty()) std::cout << " label \"" << o.label << "\"";
        std::cout << "\n";
      }
      json rest = r;
      for (const char* k : {"run", "plan"}) rest.erase(k);
      printGeneric(rest, "  ");
    }
    if (!o.watch) return;
    WatchState s;
    applyStatus(s, r);
    applyStatus(s, exchange(ControlOptions{o.ctl.socket, false}, c, {{"cmd", "status"}}));
    followRun(c, s, o.ctl.json);
  });
}

// ---- the plan queue ----
void printQueue(const json& r) {
  const json entries = r.value("queue", json::array());
  if (entries.empty()) {
    std::cout << "the queue is empty\n";
    return;
  }
  std::cout << "pos  entry  plan  (file)  label\n";
  for (const json& e : entries) {
    std::cout << textField(e, "position").value_or("?") << "  "
              << textField(e, "entry").value_or("?") << "  " << textField(e, "plan").value_or("?");
    if (auto name = textField(e, "name")) std::cout << "  (" << *name << ")";
    if (auto label = textField(e, "label"); label && !label->empty())
      std::cout << "  \"" << *label << "\"";
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
  CLI::App* q =
      app.add_subcommand("queue", "the plan queue: list it (no subcommand), move, remove, resume");
  q->group(group);
  q->require_subcommand(0, 1);
  q->fallthrough();  // --socket/--json also after move/remove/resume
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
      const json r = exchange(o->ctl, c, {{"cmd", "queue_resume"}});
      if (o->ctl.json) return;
      std::cout << "started queue entry " << textField(r, "entry").value_or("?") << " as run "
                << textField(r, "run").value_or("?") << " (plan "
                << textField(r, "plan").value_or("?") << ")\n";
    });
  });
  q->callback([o, q] {
    if (q->get_subcommands().empty()) runQueue(*o, "queue_list");
  });
}

// ---- pause / resume / abort / stop ----
void runSimple(const ControlOptions& o, const std::string& cmd, const std::string& done) {
  withClient(o, [&](ControlClient& c) {
    const json r = exchange(o, c, {{"cmd", cmd}});
    if (o.json) return;
    std::cout << done;
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
        Simple{"resume", "continue a paused run", "resumed"},
        Simple{"abort", "stop the run in an orderly way", "abort requested"},
        Simple{"stop", "EMERGENCY STOP: halt all motion now", "emergency stop sent"},
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
