// The control socket protocol of imubenchd: newline-delimited JSON (NDJSON) over a Unix stream
// socket. One request per line, one reply line per request, and event lines for subscribers.
// Pure: parsing and serialization only, no I/O (daemon/control_server.h owns the socket).
//
// Request:  {"id":7,"cmd":"pause"}
// Reply:    {"id":7,"ok":true,"result":{...}}
//           {"id":7,"ok":false,"error":{"code":"bad_argument","message":"plan: missing"}}
// Event:    {"event":"step_started","topic":"run",...}
// The full grammar of requests with examples is above parseRequest in control_protocol.cpp.
//
// Replies' results and events are specified here, next to the requests, as typed structs
// (below, "Replies and events"): the daemon builds every result and event from them and the
// CLI (tools/cli_control.cpp) parses them back into them, so both sides name each field once.
// tools/python/imubench_client.py documents the same field names.
// Adding a reply or an event:
//   1. a struct with its fields as members and one `fields(v)` listing them, v("name", member)
//      in wire order; std::optional members are left out when empty and may be absent; nested
//      structs and std::vector of them nest as objects and arrays;
//   2. an event also gets `static constexpr std::string_view kEvent` (its "event" name) and
//      `static constexpr Topic kTopic`;
//   3. the daemon sends okReply(id, toJson(result)) or ControlServer::broadcast(event); a
//      client reads fromJson<Result>(result) or parseEvent<Event>(line);
//   4. a case in the round-trip test (tests/daemon/control_protocol_test.cpp).
// Readers ignore fields they do not know (a newer daemon may add some) and refuse known ones
// of the wrong type, naming the field. This part is header-only so the CLI, which does not
// link the daemon, parses with the same code.
#pragma once

#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace imubench::daemon {

enum class Command {
  kStart,         // run a plan
  kPause,         // hold the run at the next safe point
  kResume,        // continue a paused run, or ("run") an interrupted one
  kAbort,         // stop the run in an orderly way (table to rest, recording closed)
  kStop,          // emergency stop: halt all motion now
  kRearm,         // close the table's interlock again (after a controller restart)
  kStatus,        // current state
  kSubscribe,     // receive events of topics on this connection
  kUnsubscribe,   // stop receiving events
  kListPlans,     // plans the daemon knows
  kValidatePlan,  // check a plan without running it
  kResults,       // run history or one run's results
  kExport,        // write a run's recording to a directory under the daemon's state directory
  kPing,          // liveness check of the event loop
  kQueueList,     // the plan queue (plans waiting for the run before them to complete)
  kQueueMove,     // move a queued plan to another position
  kQueueRemove,   // take a plan out of the queue
  kQueueResume,   // start the queue's head now (no run going; e.g. after an abort held it)
  kQueueAccept,   // queue the follow-up plan explain proposed for a run (daemon/follow_up.h)
};
// The wire name ("start", "list_plans", ...).
std::string_view commandName(Command c);

enum class ErrorCode {
  kBadJson,         // the line is not JSON
  kUnknownCommand,  // "cmd" names no command
  kBadArgument,     // a field is missing, unknown, or of the wrong type or range
  kTooLarge,        // the line exceeds the server's max line size
  kBusy,            // too many clients, or a run is already going
  kBadState,        // not possible in the current state (e.g. resume when not paused)
  kNotFound,        // no such run or plan
  kBadPlan,         // the plan was refused by the validator
  kForbidden,       // the peer may not send this command (daemon/control_rights.h)
  kInternal,        // the daemon failed (I/O error, ...)
};
std::string_view errorCodeName(ErrorCode c);

// Event topics a client subscribes to.
enum class Topic {
  kRun,     // run state changes, step_started / step_finished
  kStatus,  // periodic status snapshots
  kLog,     // daemon log messages of notice level and above
};
inline constexpr int kTopicCount = 3;
std::string_view topicName(Topic t);
std::optional<Topic> topicFromName(std::string_view name);

// A plan given by the client: the TOML text itself (the client reads its file with its own
// rights), or the path of a plan in the bench's plan library (plan_dir, see list_plans; the
// daemon refuses paths anywhere else without touching them).
struct PlanSource {
  enum class Kind { kPath, kInline };
  Kind kind = Kind::kPath;
  std::string text;  // the path, or the TOML text
  std::string name;  // inline only: what diagnostics call the plan (its file); empty: none
};

struct StartOptions {
  bool dry_run = false;  // validate and expand, move nothing
  std::string label;     // free text stored with the run (empty: none)
  std::string out_dir;   // where the recording goes (empty: the daemon's state directory)
  // Run after what is already queued: appended to the plan queue when a run is going (or the
  // queue is not empty), started now otherwise. Not with dry_run.
  bool queue = false;
};

struct NoArgs {};
struct StartArgs {
  PlanSource plan;
  StartOptions options;
};
struct SubscribeArgs {
  std::vector<Topic> topics;  // non-empty, no duplicates
};
struct UnsubscribeArgs {
  std::vector<Topic> topics;  // empty: all
};
struct ValidatePlanArgs {
  PlanSource plan;
};
struct ResultsArgs {
  std::optional<std::int64_t> run;  // absent: the run history
};
struct ExportArgs {
  std::int64_t run = 0;
  // The export's directory name under the daemon's export directory (exports/ next to the
  // database): one name of [A-Za-z0-9._-], not starting with '.'. Empty: "run-<id>".
  std::string dir;
};
struct ResumeArgs {
  // absent: the paused run goes on; set: this interrupted run (daemon crash, stop) continues
  // from its last finished step
  std::optional<std::int64_t> run;
};
struct QueueMoveArgs {
  std::int64_t entry = 0;  // the queue entry's id (queue_list)
  int position = 1;        // 1-based; 1 = next to start
};
struct QueueRemoveArgs {
  std::int64_t entry = 0;
};
struct QueueAcceptArgs {
  std::int64_t run = 0;  // the run whose stored follow-up proposal is queued
};
using RequestArgs =
    std::variant<NoArgs, StartArgs, SubscribeArgs, UnsubscribeArgs, ValidatePlanArgs, ResultsArgs,
                 ExportArgs, QueueMoveArgs, QueueRemoveArgs, ResumeArgs, QueueAcceptArgs>;

struct Request {
  nlohmann::json id;  // null when the client sent none; echoed in the reply
  Command command = Command::kPing;
  RequestArgs args;  // the alternative that belongs to command (NoArgs for most)
};

struct ProtocolError {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;  // where and why: "byte 12: ...", "options.label: must be a string"
};

struct ParseResult {
  bool ok = false;
  Request request;      // valid when ok
  ProtocolError error;  // valid when !ok
  nlohmann::json id;    // the request's id when it could be read (also on errors), else null
};

// Parses one request line (without its newline). Never throws; every refusal is an error.
ParseResult parseRequest(std::string_view line);

struct Reply {
  nlohmann::json id;
  bool ok = true;
  nlohmann::json result = nlohmann::json::object();  // when ok
  ProtocolError error;                               // when !ok
};
Reply okReply(nlohmann::json id, nlohmann::json result = nlohmann::json::object());
Reply errorReply(nlohmann::json id, ErrorCode code, std::string message);

// One line, newline-terminated. Invalid UTF-8 in strings (e.g. echoed client bytes) is replaced
// with U+FFFD instead of throwing.
std::string serializeReply(const Reply& reply);
// {"event":name,"topic":topic,...fields}; fields must be an object (or null for none).
std::string serializeEvent(Topic topic, std::string_view name,
                           const nlohmann::json& fields = nullptr);

// ---- Replies and events ---------------------------------------------------------------------

namespace wire {

template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <class T>
struct IsVector : std::false_type {};
template <class T>
struct IsVector<std::vector<T>> : std::true_type {};

// A visitor that does nothing: detects the structs that list their fields.
struct Probe {
  template <class T>
  void operator()(const char*, T&) {}
};
template <class T>
concept HasFields = requires(T& t, Probe& p) {
  t.fields(p);
};

// Writes a struct's fields into a JSON object.
class Writer {
 public:
  template <class T>
  void operator()(const char* key, const T& v) {
    if constexpr (IsOptional<T>::value) {
      if (v) out[key] = value(*v);
    } else {
      out[key] = value(v);
    }
  }
  template <class T>
  static nlohmann::json value(const T& v) {
    if constexpr (HasFields<T>) {
      Writer w;
      T copy = v;  // fields() is one non-const list for reading and writing
      copy.fields(w);
      return std::move(w.out);
    } else if constexpr (IsVector<T>::value) {
      nlohmann::json a = nlohmann::json::array();
      for (const auto& e : v) a.push_back(value(e));
      return a;
    } else {
      return nlohmann::json(v);
    }
  }
  nlohmann::json out = nlohmann::json::object();
};

// Reads a struct's fields from a JSON object; the first problem names the field.
class Reader {
 public:
  Reader(const nlohmann::json& j, std::string where) : j_(j), where_(std::move(where)) {}
  template <class T>
  void operator()(const char* key, T& v) {
    if (!error.empty()) return;
    const auto it = j_.find(key);
    const bool absent = it == j_.end() || it->is_null();
    if constexpr (IsOptional<T>::value) {
      v.reset();
      if (absent) return;
      typename T::value_type x{};
      if (read(*it, x, path(key))) v = std::move(x);
    } else if constexpr (std::is_same_v<T, nlohmann::json>) {
      v = absent ? nlohmann::json() : *it;  // any JSON, null included
    } else {
      if (absent) {
        error = path(key) + ": missing";
        return;
      }
      read(*it, v, path(key));
    }
  }
  template <class T>
  bool read(const nlohmann::json& j, T& v, const std::string& where) {
    if constexpr (std::is_same_v<T, nlohmann::json>) {
      v = j;
    } else if constexpr (std::is_same_v<T, bool>) {
      if (!j.is_boolean()) return fail(where, "a boolean", j);
      v = j.template get<bool>();
    } else if constexpr (std::is_integral_v<T>) {
      if (!j.is_number_integer()) return fail(where, "an integer", j);
      v = j.template get<T>();
    } else if constexpr (std::is_floating_point_v<T>) {
      if (!j.is_number() || !std::isfinite(j.template get<double>()))
        return fail(where, "a finite number", j);
      v = j.template get<T>();
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!j.is_string()) return fail(where, "a string", j);
      v = j.template get<std::string>();
    } else if constexpr (IsVector<T>::value) {
      if (!j.is_array()) return fail(where, "an array", j);
      v.assign(j.size(), typename T::value_type{});
      for (std::size_t i = 0; i < j.size(); ++i) {
        if (!read(j[i], v[i], where + "[" + std::to_string(i) + "]")) return false;
      }
    } else {
      static_assert(HasFields<T>, "a field type the wire does not know");
      if (!j.is_object()) return fail(where, "an object", j);
      Reader sub(j, where);
      v.fields(sub);
      if (!sub.error.empty()) error = sub.error;
    }
    return error.empty();
  }
  std::string error;  // empty: all fields read

 private:
  std::string path(const char* key) const { return where_.empty() ? key : where_ + "." + key; }
  bool fail(const std::string& where, const char* want, const nlohmann::json& got) {
    if (error.empty()) error = where + ": must be " + want + ", got " + got.type_name();
    return false;
  }
  const nlohmann::json& j_;
  std::string where_;
};

}  // namespace wire

// A reply's result or an event's fields as the JSON object sent.
template <class T>
nlohmann::json toJson(const T& v) {
  return wire::Writer::value(v);
}

// A reply's result (or an event line) read back; nullopt and *why (naming the field) when a
// field is missing or of the wrong type. `where` prefixes the field names in *why.
template <class T>
std::optional<T> fromJson(const nlohmann::json& j, std::string* why,
                          const std::string& where = "") {
  wire::Reader r(j, where);
  T out{};
  if (!j.is_object()) {
    if (why) *why = (where.empty() ? std::string("result") : where) + ": must be an object";
    return std::nullopt;
  }
  out.fields(r);
  if (!r.error.empty()) {
    if (why) *why = r.error;
    return std::nullopt;
  }
  return out;
}

// An event line's fields when its "event" is E's; nullopt otherwise (*why says why).
template <class E>
std::optional<E> parseEvent(const nlohmann::json& line, std::string* why) {
  const auto name = line.is_object() ? line.find("event") : line.end();
  if (!line.is_object() || name == line.end() || *name != E::kEvent) {
    if (why) *why = "not a " + std::string(E::kEvent) + " event";
    return std::nullopt;
  }
  return fromJson<E>(line, why, std::string(E::kEvent));
}

// One event line of E (see serializeEvent above).
template <class E>
std::string serializeEvent(const E& e) {
  return serializeEvent(E::kTopic, E::kEvent, toJson(e));
}

// -- events of topic run --

// Where in the run a runner event happened.
struct StepRef {
  std::int64_t run = 0;
  int step = 0;       // 0-based index into the run's steps
  std::string label;  // that step's label
  bool operator==(const StepRef&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("step", step);
    v("label", label);
  }
};

// The run's state changed ("running", "paused", "finished", "faulted", ...).
struct RunStateEvent {
  static constexpr std::string_view kEvent = "state";
  static constexpr Topic kTopic = Topic::kRun;
  StepRef at;
  std::string state;
  std::optional<std::string> exit;  // once the run ended: how ("completed", "aborted", ...)
  bool operator==(const RunStateEvent&) const = default;
  template <class V>
  void fields(V& v) {
    at.fields(v);
    v("state", state);
    v("exit", exit);
  }
};

// A step began (after any return to its start).
struct StepStartedEvent {
  static constexpr std::string_view kEvent = "step_started";
  static constexpr Topic kTopic = Topic::kRun;
  StepRef at;
  bool operator==(const StepStartedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    at.fields(v);
  }
};

struct StepFinishedEvent {
  static constexpr std::string_view kEvent = "step_finished";
  static constexpr Topic kTopic = Topic::kRun;
  StepRef at;
  bool operator==(const StepFinishedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    at.fields(v);
  }
};

// The runner raised an alarm (and paused or stopped).
struct AlarmEvent {
  static constexpr std::string_view kEvent = "alarm";
  static constexpr Topic kTopic = Topic::kRun;
  StepRef at;
  std::string message;
  bool operator==(const AlarmEvent&) const = default;
  template <class V>
  void fields(V& v) {
    at.fields(v);
    v("message", message);
  }
};

// An auto soak ended (plans/plan.h soak = "auto"): "soak_settled" when the temperature rate
// stayed below its threshold for the hold, "soak_timeout" at max_soak (the plan went on; the
// temperature point is flagged). The message says how it was measured (IMU or chamber).
struct SoakEvent {
  static constexpr std::string_view kSettled = "soak_settled";
  static constexpr std::string_view kTimeout = "soak_timeout";
  static constexpr Topic kTopic = Topic::kRun;
  StepRef at;
  bool settled = false;
  std::string message;
  bool operator==(const SoakEvent&) const = default;
  template <class V>
  void fields(V& v) {
    at.fields(v);
    v("settled", settled);
    v("message", message);
  }
};

// The IMU restarted (its counter or time stamp jumped).
struct ImuRestartEvent {
  static constexpr std::string_view kEvent = "imu_restart";
  static constexpr Topic kTopic = Topic::kRun;
  std::uint64_t restarts = 0;       // since the daemon started
  std::string message;              // the decoder's description
  std::optional<std::int64_t> run;  // the run going, if any
  bool operator==(const ImuRestartEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("restarts", restarts);
    v("message", message);
    v("run", run);
  }
};

// A run was closed and stored.
struct RunFinishedEvent {
  static constexpr std::string_view kEvent = "run_finished";
  static constexpr Topic kTopic = Topic::kRun;
  std::int64_t run = 0;
  std::string state;  // the stored run state ("finished", "aborted", "faulted")
  std::string exit;   // why it ended
  bool operator==(const RunFinishedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("state", state);
    v("exit", exit);
  }
};

// A plan was appended to the queue (also the "queued" field of a start reply).
struct QueuedEvent {
  static constexpr std::string_view kEvent = "queued";
  static constexpr Topic kTopic = Topic::kRun;
  std::int64_t entry = 0;     // the queue entry's id
  std::int64_t position = 0;  // 1-based
  std::string plan;
  bool operator==(const QueuedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("entry", entry);
    v("position", position);
    v("plan", plan);
  }
};

struct QueueStartedEvent {
  static constexpr std::string_view kEvent = "queue_started";
  static constexpr Topic kTopic = Topic::kRun;
  std::int64_t entry = 0;
  std::int64_t run = 0;
  std::string plan;
  bool operator==(const QueueStartedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("entry", entry);
    v("run", run);
    v("plan", plan);
  }
};

// The queue's head could not start; the queue waits (queue_resume).
struct QueueHeldEvent {
  static constexpr std::string_view kEvent = "queue_held";
  static constexpr Topic kTopic = Topic::kRun;
  std::string reason;
  bool operator==(const QueueHeldEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("reason", reason);
  }
};

struct RearmedEvent {
  static constexpr std::string_view kEvent = "rearmed";
  static constexpr Topic kTopic = Topic::kRun;
  std::int64_t run = 0;
  bool operator==(const RearmedEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
  }
};

// -- events of topic status --

// Periodic progress of the run going.
struct ProgressEvent {
  static constexpr std::string_view kEvent = "progress";
  static constexpr Topic kTopic = Topic::kStatus;
  std::int64_t run = 0;
  std::string state;
  double progress = 0.0;  // 0..1 of the planned time
  double eta_s = 0.0;     // planned time left
  int step = 0;           // the step shown, 0-based
  std::string label;
  bool operator==(const ProgressEvent&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("state", state);
    v("progress", progress);
    v("eta_s", eta_s);
    v("step", step);
    v("label", label);
  }
};

// -- replies (the "result" object) --

struct PingReply {  // ping
  bool pong = true;
  bool operator==(const PingReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("pong", pong);
  }
};

struct TopicsReply {  // subscribe, unsubscribe: the topics subscribed now
  std::vector<std::string> topics;
  bool operator==(const TopicsReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("topics", topics);
  }
};

// A plan as the daemon expanded it.
struct PlanSummary {
  std::string plan;        // its [plan] name
  std::int64_t steps = 0;  // steps (segments) it expands to
  double planned_s = 0.0;  // planned duration
  bool operator==(const PlanSummary&) const = default;
  template <class V>
  void fields(V& v) {
    v("plan", plan);
    v("steps", steps);
    v("planned_s", planned_s);
  }
};

// start (and queue_resume, with entry): the run that started.
struct StartReply {
  std::int64_t run = 0;
  PlanSummary summary;
  std::optional<std::int64_t> entry;  // queue_resume: the queue entry that started
  bool operator==(const StartReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    summary.fields(v);
    v("entry", entry);
  }
};

struct DryRunReply {  // start with dry_run
  bool dry_run = true;
  PlanSummary summary;
  bool operator==(const DryRunReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("dry_run", dry_run);
    summary.fields(v);
  }
};

struct QueuedReply {  // start with queue, when it was queued
  QueuedEvent queued;
  bool operator==(const QueuedReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("queued", queued);
  }
};

struct StopReply {  // stop
  bool stopped = true;
  bool operator==(const StopReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("stopped", stopped);
  }
};

struct RunCommandReply {  // pause, resume, abort
  std::int64_t run = 0;
  std::string state;  // the runner's state after the command
  bool operator==(const RunCommandReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("state", state);
  }
};

// The table as last read (status, rearm).
struct TableStatus {
  std::string interlock;  // "closed", "open", "tripped"
  bool estop = false;
  bool fault = false;
  std::string state;                 // the driver's connection state
  std::optional<std::string> error;  // the last table error, if any
  // The last read's axis angles, deg, and whether any axis moves (absent after a read that got
  // no answer).
  std::optional<std::vector<double>> angles_deg;
  std::optional<bool> moving;
  // Seconds since the table last answered a poll (it is polled whenever the daemon runs);
  // absent before the first answer.
  std::optional<double> age_s = std::nullopt;
  bool operator==(const TableStatus&) const = default;
  template <class V>
  void fields(V& v) {
    v("interlock", interlock);
    v("estop", estop);
    v("fault", fault);
    v("state", state);
    v("error", error);
    v("angles_deg", angles_deg);
    v("moving", moving);
    v("age_s", age_s);
  }
};

struct RearmReply {  // rearm
  TableStatus table;
  bool operator==(const RearmReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("table", table);
  }
};

// The step a status shows.
struct StatusStep {
  int index = 0;  // 0-based
  std::string label;
  std::string kind;        // segment kind: static, rotate, move, soak
  std::int64_t count = 0;  // steps in the run
  bool operator==(const StatusStep&) const = default;
  template <class V>
  void fields(V& v) {
    v("index", index);
    v("label", label);
    v("kind", kind);
    v("count", count);
  }
};

// The lab mirror (issue 30, lab/shipper.h): whether the bench's store reaches the lab's
// PostgreSQL, and how much waits in the outbox meanwhile.
struct LabStatus {
  std::string state;          // starting, ok, fault
  std::string fault;          // none, unreachable, authentication, rights, schema, ...
  std::string message;        // the fault in one line (never credentials); empty when ok
  std::int64_t backlog = -1;  // outbox items not yet in the lab (-1: not known yet)
  std::int64_t shipped = 0;   // items shipped since the daemon started
  // [lab] mirror_samples only (absent otherwise): raw sample rows waiting (-1: not known yet,
  // the lab was never reached) and shipped since the daemon started.
  std::optional<std::int64_t> samples_backlog;
  std::optional<std::int64_t> samples_shipped;
  bool operator==(const LabStatus&) const = default;
  template <class V>
  void fields(V& v) {
    v("state", state);
    v("fault", fault);
    v("message", message);
    v("backlog", backlog);
    v("shipped", shipped);
    v("samples_backlog", samples_backlog);
    v("samples_shipped", samples_shipped);
  }
};

// The lab mirror went into a fault or out of it (topic status): "lab_alarm" with the fault,
// "lab_ok" once the lab is reached again.
struct LabAlarmEvent {
  static constexpr std::string_view kAlarm = "lab_alarm";
  static constexpr std::string_view kOk = "lab_ok";
  static constexpr Topic kTopic = Topic::kStatus;
  LabStatus lab;
  bool operator==(const LabAlarmEvent&) const = default;
  template <class V>
  void fields(V& v) {
    lab.fields(v);
  }
};

struct StatusReply {  // status
  std::string bench;
  std::string state;                 // "idle" or the runner's state
  std::optional<double> imu_time_s;  // newest IMU time stamp
  std::uint64_t imu_lost_samples = 0;
  std::uint64_t imu_bad_frames = 0;
  std::uint64_t imu_restarts = 0;
  TableStatus table;
  std::optional<std::uint64_t> queued;  // plans waiting in the queue
  // With a run going:
  std::optional<std::int64_t> run;
  std::optional<std::string> plan;
  std::optional<double> progress;  // 0..1
  std::optional<double> eta_s;
  std::optional<StatusStep> step;
  std::optional<LabStatus> lab;  // with a [lab] database in the bench file
  bool operator==(const StatusReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("bench", bench);
    v("state", state);
    v("imu_time_s", imu_time_s);
    v("imu_lost_samples", imu_lost_samples);
    v("imu_bad_frames", imu_bad_frames);
    v("imu_restarts", imu_restarts);
    v("table", table);
    v("queued", queued);
    v("run", run);
    v("plan", plan);
    v("progress", progress);
    v("eta_s", eta_s);
    v("step", step);
    v("lab", lab);
  }
};

struct PlanListReply {  // list_plans
  std::string plan_dir;
  std::vector<std::string> plans;  // paths relative to plan_dir
  bool operator==(const PlanListReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("plan_dir", plan_dir);
    v("plans", plans);
  }
};

struct ValidatePlanReply {  // validate_plan
  PlanSummary summary;
  bool operator==(const ValidatePlanReply&) const = default;
  template <class V>
  void fields(V& v) {
    summary.fields(v);
  }
};

struct RunListEntry {
  std::int64_t run = 0;
  std::string plan;
  std::string state;
  std::string exit;
  double started_unix_s = 0.0;
  bool operator==(const RunListEntry&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("plan", plan);
    v("state", state);
    v("exit", exit);
    v("started_unix_s", started_unix_s);
  }
};

struct RunListReply {  // results without run: the run history
  std::vector<RunListEntry> runs;
  bool operator==(const RunListReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("runs", runs);
  }
};

struct StoredResultEntry {
  std::string kind;
  nlohmann::json json;  // the stored result document as it is
  bool operator==(const StoredResultEntry&) const = default;
  template <class V>
  void fields(V& v) {
    v("kind", kind);
    v("json", json);
  }
};

struct RunResultsReply {  // results with run
  std::int64_t run = 0;
  std::string state;
  std::string exit;
  std::vector<StoredResultEntry> results;
  bool operator==(const RunResultsReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("state", state);
    v("exit", exit);
    v("results", results);
  }
};

struct ExportReply {  // export
  std::int64_t run = 0;
  std::string dir;  // where the recording was written
  std::uint64_t imu_samples = 0;
  bool operator==(const ExportReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("run", run);
    v("dir", dir);
    v("imu_samples", imu_samples);
  }
};

struct QueueListEntry {
  std::int64_t entry = 0;
  std::int64_t position = 0;  // 1-based
  std::string plan;
  std::string name;  // the plan's source (library path or the client's file name)
  std::string label;
  double added_unix_s = 0.0;
  bool operator==(const QueueListEntry&) const = default;
  template <class V>
  void fields(V& v) {
    v("entry", entry);
    v("position", position);
    v("plan", plan);
    v("name", name);
    v("label", label);
    v("added_unix_s", added_unix_s);
  }
};

struct QueueReply {  // queue_list, queue_move, queue_remove: the queue as it is now
  std::vector<QueueListEntry> queue;
  bool operator==(const QueueReply&) const = default;
  template <class V>
  void fields(V& v) {
    v("queue", queue);
  }
};

}  // namespace imubench::daemon
