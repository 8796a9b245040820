// The control socket protocol of imubenchd: newline-delimited JSON (NDJSON) over a Unix stream
// socket. One request per line, one reply line per request, and event lines for subscribers.
// Pure: parsing and serialization only, no I/O (daemon/control_server.h owns the socket).
//
// Request:  {"id":7,"cmd":"pause"}
// Reply:    {"id":7,"ok":true,"result":{...}}
//           {"id":7,"ok":false,"error":{"code":"bad_argument","message":"plan: missing"}}
// Event:    {"event":"step_started","topic":"run",...}
// The full grammar with examples is above parseRequest in control_protocol.cpp.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
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
using RequestArgs =
    std::variant<NoArgs, StartArgs, SubscribeArgs, UnsubscribeArgs, ValidatePlanArgs, ResultsArgs,
                 ExportArgs, QueueMoveArgs, QueueRemoveArgs, ResumeArgs>;

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

}  // namespace imubench::daemon
