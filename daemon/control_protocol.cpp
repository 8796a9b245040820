#include "daemon/control_protocol.h"

#include <algorithm>
#include <array>
#include <initializer_list>
#include <limits>
#include <utility>

#include "io/enum_names.h"

namespace imubench::daemon {

using nlohmann::json;

namespace {

constexpr std::array<io::Named<Command, std::string_view>, 19> kCommands{{
    {Command::kStart, "start"},
    {Command::kPause, "pause"},
    {Command::kResume, "resume"},
    {Command::kAbort, "abort"},
    {Command::kStop, "stop"},
    {Command::kRearm, "rearm"},
    {Command::kStatus, "status"},
    {Command::kSubscribe, "subscribe"},
    {Command::kUnsubscribe, "unsubscribe"},
    {Command::kListPlans, "list_plans"},
    {Command::kValidatePlan, "validate_plan"},
    {Command::kResults, "results"},
    {Command::kExport, "export"},
    {Command::kPing, "ping"},
    {Command::kQueueList, "queue_list"},
    {Command::kQueueMove, "queue_move"},
    {Command::kQueueRemove, "queue_remove"},
    {Command::kQueueResume, "queue_resume"},
    {Command::kQueueAccept, "queue_accept"},
}};

constexpr std::array<io::Named<Topic, std::string_view>, kTopicCount> kTopics{{
    {Topic::kRun, "run"},
    {Topic::kStatus, "status"},
    {Topic::kLog, "log"},
}};

// Labels end up in the run history and in every status reply: bounded so they stay readable.
constexpr std::size_t kMaxLabelBytes = 200;
// A plan's diagnostic name (its file path on the client) and an export's directory name:
// bounded like a path component or a path, so they stay readable in replies and logs.
constexpr std::size_t kMaxPlanNameBytes = 4096;
constexpr std::size_t kMaxExportNameBytes = 255;

// Bytes of a client's text quoted in an error message: replies stay small whatever was sent.
constexpr std::size_t kMaxQuotedBytes = 80;

std::string quote(std::string_view s) {
  if (s.size() <= kMaxQuotedBytes) return "\"" + std::string(s) + "\"";
  return "\"" + std::string(s.substr(0, kMaxQuotedBytes)) + "\"... (" + std::to_string(s.size()) +
         " bytes)";
}

// A JSON value as the client sent it, bounded like quote().
std::string shown(const json& v) {
  std::string text = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > kMaxQuotedBytes) text = text.substr(0, kMaxQuotedBytes) + "...";
  return text;
}

std::string commandList() {
  return io::joinNames(kCommands, ", ");
}

std::string topicList() {
  return io::joinNames(kTopics, ", ");
}

std::string joinPath(std::string_view where, std::string_view key) {
  return where.empty() ? std::string(key) : std::string(where) + "." + std::string(key);
}

bool fail(ProtocolError* err, ErrorCode code, std::string message) {
  *err = {code, std::move(message)};
  return false;
}

// Refuses any key of obj not in allowed, naming the first one (keys are sorted by json).
bool refuseUnknownFields(const json& obj, std::initializer_list<std::string_view> allowed,
                         std::string_view where, std::string_view owner, ProtocolError* err) {
  for (const auto& [key, value] : obj.items()) {
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string known;
    for (std::string_view a : allowed) known += (known.empty() ? "" : ", ") + std::string(a);
    // The key is the client's: quoted and bounded like any text of theirs.
    return fail(
        err, ErrorCode::kBadArgument,
        (key.size() > kMaxQuotedBytes ? joinPath(where, quote(key)) : joinPath(where, key)) +
            ": unknown field of " + std::string(owner) + " (known: " + known + ")");
  }
  return true;
}

// A string field; *present tells whether it was there (missing is an error when required).
bool readString(const json& obj, std::string_view key, std::string_view where, bool required,
                std::string* out, ProtocolError* err) {
  const auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) return fail(err, ErrorCode::kBadArgument, joinPath(where, key) + ": missing");
    return true;
  }
  if (!it->is_string())
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be a string, got " + it->type_name());
  *out = it->get<std::string>();
  // A NUL (\u0000) would silently cut the string short in every C API it reaches.
  if (out->find('\0') != std::string::npos)
    return fail(err, ErrorCode::kBadArgument, joinPath(where, key) + ": contains a NUL byte");
  return true;
}

bool readNonEmptyString(const json& obj, std::string_view key, std::string_view where,
                        bool required, std::string* out, ProtocolError* err) {
  if (!readString(obj, key, where, required, out, err)) return false;
  if (obj.contains(key) && out->empty())
    return fail(err, ErrorCode::kBadArgument, joinPath(where, key) + ": must not be empty");
  return true;
}

bool readAbsolutePath(const json& obj, std::string_view key, std::string_view where, bool required,
                      std::string* out, ProtocolError* err) {
  if (!readNonEmptyString(obj, key, where, required, out, err)) return false;
  // The daemon's working directory is not the client's: a relative path would mislead.
  if (obj.contains(key) && out->front() != '/')
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be an absolute path, got " + quote(*out));
  return true;
}

bool readBool(const json& obj, std::string_view key, std::string_view where, bool* out,
              ProtocolError* err) {
  const auto it = obj.find(key);
  if (it == obj.end()) return true;
  if (!it->is_boolean())
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be true or false, got " + it->type_name());
  *out = it->get<bool>();
  return true;
}

// Run and queue entry ids (SQLite rowids) and queue positions are positive integers; 1.0 or
// "3" are refused, not converted. noun names the kind in the message ("run id").
bool readPositive(const json& obj, std::string_view key, bool required, std::string_view noun,
                  std::optional<std::int64_t>* out, ProtocolError* err) {
  const auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) return fail(err, ErrorCode::kBadArgument, std::string(key) + ": missing");
    return true;
  }
  const std::string where(key);
  if (!it->is_number_integer())
    return fail(err, ErrorCode::kBadArgument,
                where + ": must be an integer " + std::string(noun) + ", got " + shown(*it));
  if (it->is_number_unsigned() &&
      it->get<std::uint64_t>() > std::uint64_t{std::numeric_limits<std::int64_t>::max()})
    return fail(err, ErrorCode::kBadArgument, where + ": out of range");
  const std::int64_t v = it->get<std::int64_t>();
  if (v < 1) return fail(err, ErrorCode::kBadArgument, where + ": must be >= 1");
  *out = v;
  return true;
}

bool readRunId(const json& obj, std::string_view key, bool required,
               std::optional<std::int64_t>* out, ProtocolError* err) {
  return readPositive(obj, key, required, "run id", out, err);
}

bool readPlan(const json& obj, PlanSource* out, ProtocolError* err) {
  const auto it = obj.find("plan");
  if (it == obj.end()) return fail(err, ErrorCode::kBadArgument, "plan: missing");
  if (!it->is_object())
    return fail(err, ErrorCode::kBadArgument,
                std::string("plan: must be an object {\"path\":...} or {\"toml\":...}, got ") +
                    it->type_name());
  if (!refuseUnknownFields(*it, {"path", "toml", "name"}, "plan", "plan", err)) return false;
  const bool has_path = it->contains("path");
  if (has_path == it->contains("toml"))
    return fail(err, ErrorCode::kBadArgument, "plan: needs exactly one of \"path\" or \"toml\"");
  out->kind = has_path ? PlanSource::Kind::kPath : PlanSource::Kind::kInline;
  if (has_path) {
    if (it->contains("name"))
      return fail(err, ErrorCode::kBadArgument,
                  "plan.name: only with \"toml\" (a path names the plan itself)");
    return readAbsolutePath(*it, "path", "plan", true, &out->text, err);
  }
  if (!readNonEmptyString(*it, "name", "plan", false, &out->name, err)) return false;
  if (out->name.size() > kMaxPlanNameBytes)
    return fail(err, ErrorCode::kBadArgument,
                "plan.name: longer than " + std::to_string(kMaxPlanNameBytes) + " bytes");
  return readNonEmptyString(*it, "toml", "plan", true, &out->text, err);
}

// An export's directory name: one path component the daemon creates under its export
// directory, so no client-named path is ever written.
bool readExportName(const json& obj, std::string* out, ProtocolError* err) {
  if (!readNonEmptyString(obj, "dir", "", false, out, err)) return false;
  const auto bad = [out, err](const std::string& why) {
    return fail(err, ErrorCode::kBadArgument,
                "dir: " + why + ", got " + quote(*out) +
                    " (a directory name under the daemon's export directory; the reply "
                    "says where it went)");
  };
  if (out->size() > kMaxExportNameBytes)
    return bad("longer than " + std::to_string(kMaxExportNameBytes) + " bytes");
  if (!out->empty() && out->front() == '.') return bad("must not start with '.'");
  for (const char ch : *out) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '.' || ch == '_' || ch == '-';
    if (!ok) return bad("must be a single name of letters, digits, '.', '_' and '-'");
  }
  return true;
}

bool readStartOptions(const json& obj, StartOptions* out, ProtocolError* err) {
  const auto it = obj.find("options");
  if (it == obj.end()) return true;
  if (!it->is_object())
    return fail(err, ErrorCode::kBadArgument,
                std::string("options: must be an object, got ") + it->type_name());
  if (!refuseUnknownFields(*it, {"dry_run", "label", "out_dir", "queue"}, "options", "options",
                           err))
    return false;
  if (!readBool(*it, "dry_run", "options", &out->dry_run, err)) return false;
  if (!readBool(*it, "queue", "options", &out->queue, err)) return false;
  if (out->queue && out->dry_run)
    return fail(err, ErrorCode::kBadArgument,
                "options.queue: not with dry_run (a dry run only validates; use validate_plan)");
  if (!readString(*it, "label", "options", false, &out->label, err)) return false;
  if (out->label.size() > kMaxLabelBytes)
    return fail(err, ErrorCode::kBadArgument,
                "options.label: longer than " + std::to_string(kMaxLabelBytes) + " bytes");
  return readAbsolutePath(*it, "out_dir", "options", false, &out->out_dir, err);
}

bool readTopics(const json& obj, bool required, std::vector<Topic>* out, ProtocolError* err) {
  const auto it = obj.find("topics");
  if (it == obj.end()) {
    if (required) return fail(err, ErrorCode::kBadArgument, "topics: missing");
    return true;
  }
  if (!it->is_array() || it->empty())
    return fail(err, ErrorCode::kBadArgument,
                "topics: must be a non-empty array of topic names (" + topicList() + ")");
  for (std::size_t i = 0; i < it->size(); ++i) {
    const std::string where = "topics[" + std::to_string(i) + "]";
    const json& v = (*it)[i];
    if (!v.is_string())
      return fail(err, ErrorCode::kBadArgument, where + ": must be a string, got " + v.type_name());
    const auto topic = topicFromName(v.get<std::string>());
    if (!topic)
      return fail(err, ErrorCode::kBadArgument,
                  where + ": unknown topic " + quote(v.get<std::string>()) +
                      " (known: " + topicList() + ")");
    if (std::find(out->begin(), out->end(), *topic) != out->end())
      return fail(err, ErrorCode::kBadArgument,
                  where + ": duplicate topic " + quote(topicName(*topic)));
    out->push_back(*topic);
  }
  return true;
}

// The request's id: a string or an integer (JSON-RPC's choice, minus fractions), echoed as is.
bool readId(const json& obj, json* id, ProtocolError* err) {
  const auto it = obj.find("id");
  if (it == obj.end()) return true;
  if (!it->is_string() && !it->is_number_integer())
    return fail(err, ErrorCode::kBadArgument,
                std::string("id: must be a string or an integer, got ") + it->type_name());
  *id = *it;
  return true;
}

bool readCommandName(const json& obj, Command* out, ProtocolError* err) {
  const auto it = obj.find("cmd");
  if (it == obj.end()) return fail(err, ErrorCode::kBadArgument, "cmd: missing");
  if (!it->is_string())
    return fail(err, ErrorCode::kBadArgument,
                std::string("cmd: must be a string, got ") + it->type_name());
  const std::string name = it->get<std::string>();
  if (const auto c = io::valueOf(kCommands, name)) {
    *out = *c;
    return true;
  }
  return fail(err, ErrorCode::kUnknownCommand,
              "cmd: unknown command " + quote(name) + " (known: " + commandList() + ")");
}

// queue_move {"entry":N,"position":P} and queue_remove {"entry":N}.
bool readQueueArgs(const json& obj, Command c, const std::string& owner, RequestArgs* out,
                   ProtocolError* err) {
  const bool move = c == Command::kQueueMove;
  if (move ? !refuseUnknownFields(obj, {"id", "cmd", "entry", "position"}, "", owner, err)
           : !refuseUnknownFields(obj, {"id", "cmd", "entry"}, "", owner, err))
    return false;
  std::optional<std::int64_t> entry;
  if (!readPositive(obj, "entry", true, "queue entry id", &entry, err)) return false;
  if (!move) {
    *out = QueueRemoveArgs{*entry};
    return true;
  }
  std::optional<std::int64_t> position;
  if (!readPositive(obj, "position", true, "position (1 = next)", &position, err)) return false;
  if (*position > std::numeric_limits<int>::max())
    return fail(err, ErrorCode::kBadArgument, "position: out of range");
  *out = QueueMoveArgs{*entry, static_cast<int>(*position)};
  return true;
}

// The arguments of one command; refuses fields the command does not take.
bool readArgs(const json& obj, Command c, RequestArgs* out, ProtocolError* err) {
  const std::string owner = "command " + quote(commandName(c));
  switch (c) {
    case Command::kStart: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "plan", "options"}, "", owner, err)) return false;
      StartArgs a;
      if (!readPlan(obj, &a.plan, err) || !readStartOptions(obj, &a.options, err)) return false;
      *out = std::move(a);
      return true;
    }
    case Command::kSubscribe:
    case Command::kUnsubscribe: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "topics"}, "", owner, err)) return false;
      std::vector<Topic> topics;
      if (!readTopics(obj, c == Command::kSubscribe, &topics, err)) return false;
      if (c == Command::kSubscribe)
        *out = SubscribeArgs{std::move(topics)};
      else
        *out = UnsubscribeArgs{std::move(topics)};
      return true;
    }
    case Command::kValidatePlan: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "plan"}, "", owner, err)) return false;
      ValidatePlanArgs a;
      if (!readPlan(obj, &a.plan, err)) return false;
      *out = std::move(a);
      return true;
    }
    case Command::kResults: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "run"}, "", owner, err)) return false;
      ResultsArgs a;
      if (!readRunId(obj, "run", false, &a.run, err)) return false;
      *out = a;
      return true;
    }
    case Command::kExport: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "run", "dir"}, "", owner, err)) return false;
      std::optional<std::int64_t> run;
      ExportArgs a;
      if (!readRunId(obj, "run", true, &run, err)) return false;
      if (!readExportName(obj, &a.dir, err)) return false;
      a.run = *run;
      *out = std::move(a);
      return true;
    }
    case Command::kQueueMove:
    case Command::kQueueRemove:
      return readQueueArgs(obj, c, owner, out, err);
    case Command::kQueueAccept: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "run"}, "", owner, err)) return false;
      std::optional<std::int64_t> run;
      if (!readRunId(obj, "run", true, &run, err)) return false;
      *out = QueueAcceptArgs{*run};
      return true;
    }
    case Command::kResume: {
      if (!refuseUnknownFields(obj, {"id", "cmd", "run"}, "", owner, err)) return false;
      ResumeArgs a;
      if (!readRunId(obj, "run", false, &a.run, err)) return false;
      *out = a;
      return true;
    }
    default:
      *out = NoArgs{};
      return refuseUnknownFields(obj, {"id", "cmd"}, "", owner, err);
  }
}

// nlohmann's what() is "[json.exception.parse_error.101] parse error at line 1, column 5:
// syntax error while parsing value - ...": keep the reason, the byte offset says where.
std::string parseErrorReason(const json::parse_error& e) {
  const std::string what = e.what();
  const auto column = what.find("column ");
  const auto colon = what.find(": ", column == std::string::npos ? 0 : column);
  return colon == std::string::npos ? what : what.substr(colon + 2);
}

}  // namespace

std::string_view commandName(Command c) {
  return io::nameOf(kCommands, c, "?");
}

constexpr io::Named<ErrorCode, std::string_view> kErrorCodeNames[] = {
    {ErrorCode::kBadJson, "bad_json"},
    {ErrorCode::kUnknownCommand, "unknown_command"},
    {ErrorCode::kBadArgument, "bad_argument"},
    {ErrorCode::kTooLarge, "too_large"},
    {ErrorCode::kBusy, "busy"},
    {ErrorCode::kBadState, "bad_state"},
    {ErrorCode::kNotFound, "not_found"},
    {ErrorCode::kBadPlan, "bad_plan"},
    {ErrorCode::kForbidden, "forbidden"},
    {ErrorCode::kInternal, "internal"},
};

std::string_view errorCodeName(ErrorCode c) {
  return io::nameOf(kErrorCodeNames, c, "internal");
}

std::string_view topicName(Topic t) {
  return io::nameOf(kTopics, t, "?");
}

std::optional<Topic> topicFromName(std::string_view name) {
  return io::valueOf(kTopics, name);
}

// Grammar (one JSON object per line, UTF-8, at most the server's max line size; blank lines
// are ignored). Every request may carry "id" (string or integer), echoed in its reply. Fields
// not listed are refused with bad_argument naming them. Paths are absolute.
//
// Plans: a client sends the plan's text ("toml"), read from its file with the client's own
// rights; "name" (optional, e.g. that file's path) is what the diagnostics call it. A "path"
// is honoured only inside the bench's plan library (plan_dir, as list_plans reports it): the
// daemon reads it off its event loop (regular files up to 1 MiB) and answers when done;
// any other path is refused (bad_argument, "send the plan's text") without being touched.
//
//   {"cmd":"ping"}                                   -> {"id":null,"ok":true,"result":{}}
//   {"id":1,"cmd":"start","plan":{"path":"/etc/imubench/plans/two_axis_12run.toml"}}
//   {"id":2,"cmd":"start","plan":{"toml":"[plan]\nname = \"x\"\n...","name":"/home/op/x.toml"},
//    "options":{"dry_run":true,"label":"unit 42","out_dir":"/var/lib/imubench/runs/42"}}
//   {"id":3,"cmd":"pause"}      {"id":4,"cmd":"resume"}     {"id":5,"cmd":"abort"}
//   {"id":16,"cmd":"resume","run":42}  (run 42 was interrupted by a daemon crash or stop: it
//                                goes on from its last finished step, appending to the run;
//                                without "run": the paused run goes on)
//   {"id":6,"cmd":"stop"}       (emergency stop)            {"id":7,"cmd":"status"}
//   {"id":15,"cmd":"rearm"}     (close the table's interlock again after a controller
//                                restart; no run, or a paused one; then "resume")
//   {"id":8,"cmd":"subscribe","topics":["run","status","log"]}
//   {"id":9,"cmd":"unsubscribe"}                     (all topics; or "topics":[...])
//   {"id":10,"cmd":"list_plans"}
//   {"id":11,"cmd":"validate_plan","plan":{"toml":"...","name":"/home/op/p.toml"}}
//   {"id":12,"cmd":"results"}   {"id":13,"cmd":"results","run":42}
//   {"id":14,"cmd":"export","run":42,"dir":"unit42"}  -> {"result":{"run":42,"imu_samples":..,
//        "dir":"/var/lib/imubench/exports/unit42"}}  (the daemon writes only under exports/
//        next to its database; "dir" is optional, default "run-42"; an existing one is refused)
//
// The plan queue (stored in the database, so it survives a daemon restart). A start with
// "queue":true while a run is going (or while plans are already queued) validates the plan
// against the bench now and appends it; otherwise it starts at once like any start:
//   {"id":20,"cmd":"start","plan":{"toml":"...","name":"/home/op/b.toml"},
//    "options":{"queue":true,"label":"unit 43"}}
//        -> {"result":{"queued":{"entry":7,"position":2,"plan":"b"}}}   (refused: bad_plan)
//   {"id":21,"cmd":"queue_list"} -> {"result":{"queue":[{"entry":6,"position":1,"plan":"a",
//        "name":"/home/op/a.toml","label":"","added_unix_s":1.7e9},...]}}
//   {"id":22,"cmd":"queue_move","entry":7,"position":1}   (1 = next; replies the new queue)
//   {"id":23,"cmd":"queue_remove","entry":6}               (replies the new queue)
//   {"id":24,"cmd":"queue_resume"}   (no run going: start the head now; replies as start, plus
//                                     "entry")
//   {"id":25,"cmd":"queue_accept","run":41}  (queue the follow-up plan stored with run 41's
//        results, daemon/follow_up.h; replies as a queued start; not_found: no proposal stored,
//        bad_state: the proposal holds no plan, with its reason)
// When a run ends completed, the queue's head starts by itself (event "queue_started" on topic
// run; if it cannot start, e.g. the bench is in emergency stop, it stays queued: event
// "queue_held" with the reason). After an abort, a fault, an emergency stop or a daemon restart
// the queue holds: nothing starts until the operator sends queue_resume (or starts a plan,
// whose completion lets the queue go on).
//
// Replies carry the request's id. Work that may block (a library plan read, an export) runs
// off the daemon's event loop and is answered when done: a client that sends several requests
// without waiting may get those replies after later ones, and matches them by id.
//
// Connections: max_clients take every command; a few more (reserved slots) only stop, status
// and ping, so the emergency stop gets through a full server (others: busy). A connection that
// sends nothing for the idle timeout (the bench file's [control] idle_timeout) is closed, unless
// it is subscribed and reads its events (a watcher).
//
// Errors (the id is echoed when it could be read):
//   {"cmd":"ping"                -> bad_json     "byte 14: syntax error while parsing object ..."
//   {"cmd":"fly"}                -> unknown_command "cmd: unknown command \"fly\" (known: ...)"
//   {"cmd":"pause","force":1}    -> bad_argument "force: unknown field of command \"pause\" ..."
//   {"cmd":"results","run":1.5}  -> bad_argument "run: must be an integer run id, got 1.5"
//   {"cmd":"export","run":1,"dir":"/tmp/x"} -> bad_argument "dir: must be a single name ..."
//   {"cmd":"queue_move","entry":7}          -> bad_argument "position: missing"
//   {"cmd":"queue_remove","entry":99}       -> not_found "queue entry 99 is not queued"
//   {"cmd":"ping","id":1e400}    -> bad_json     "number out of range: number overflow parsing
//                                   '1e400'" (no double holds it)
//   [[[[... (over 32 levels)     -> bad_json     "request: arrays and objects nested more than 32
//                                   deep"
//   a line over the size limit   -> too_large (sent by the server; the line is discarded)
//   {"cmd":"start",...} from a user outside the bench's command group (daemon/control_rights.h)
//                                -> forbidden "start: forbidden for uid 1000: commanding the
//                                   bench needs group imubench (gid 1001)" (stop, ping: never)
namespace {

// Requests nest three levels deep ({"options":{...}}); anything much deeper is abuse. Bounded
// before parsing, because copying or dumping a json value recurses once per level.
constexpr int kMaxNesting = 32;
// How deep line's arrays and objects nest (brackets inside strings do not count), stopping at
// the first level beyond limit. A lexical scan: malformed JSON is left to the parser.
int nestingDepth(std::string_view line, int limit) {
  int depth = 0;
  int deepest = 0;
  bool in_string = false;
  bool escaped = false;
  for (const char ch : line) {
    if (in_string) {
      if (escaped)
        escaped = false;
      else if (ch == '\\')
        escaped = true;
      else if (ch == '"')
        in_string = false;
      continue;
    }
    if (ch == '"') {
      in_string = true;
    } else if (ch == '[' || ch == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if (ch == ']' || ch == '}') {
      --depth;
    }
  }
  return deepest;
}

// Shortens a message that quotes the client's text (the reply stays small; invalid UTF-8 cut
// here is replaced when the reply is serialized).
std::string bounded(std::string message) {
  constexpr std::size_t kMax = 2 * kMaxQuotedBytes + 200;
  if (message.size() > kMax) message = message.substr(0, kMax) + "...";
  return message;
}

// nlohmann's what() without its "[json.exception.out_of_range.406] " tag.
std::string withoutTag(std::string_view what) {
  if (what.rfind("[json.exception.", 0) == 0) {
    if (const auto end = what.find("] "); end != std::string_view::npos)
      what.remove_prefix(end + 2);
  }
  return std::string(what);
}

// The parse proper; every nlohmann exception (parse_error, out_of_range for a number like
// 1e400, type_error) is caught by the caller.
ParseResult parseChecked(std::string_view line) {
  ParseResult r;
  json doc;
  try {
    doc = json::parse(line.begin(), line.end());
  } catch (const json::parse_error& e) {
    r.error = {ErrorCode::kBadJson,
               bounded("byte " + std::to_string(e.byte) + ": " + parseErrorReason(e))};
    return r;
  } catch (const json::out_of_range& e) {
    // A number no double holds (1e400, a 400-digit integer): valid grammar, no value.
    r.error = {ErrorCode::kBadJson, bounded("number out of range: " + withoutTag(e.what()))};
    return r;
  }
  if (!doc.is_object()) {
    r.error = {ErrorCode::kBadArgument,
               std::string("request: must be a JSON object, got ") + doc.type_name()};
    return r;
  }
  if (!readId(doc, &r.id, &r.error)) return r;
  r.request.id = r.id;
  if (!readCommandName(doc, &r.request.command, &r.error)) return r;
  r.ok = readArgs(doc, r.request.command, &r.request.args, &r.error);
  return r;
}

}  // namespace

ParseResult parseRequest(std::string_view line) {
  if (const int depth = nestingDepth(line, kMaxNesting); depth > kMaxNesting) {
    ParseResult r;
    r.error = {ErrorCode::kBadJson, "request: arrays and objects nested more than " +
                                        std::to_string(kMaxNesting) + " deep"};
    return r;
  }
  try {
    return parseChecked(line);
  } catch (const std::exception& e) {
    // Nothing the client sends may throw out of here (the daemon's loop would die): whatever
    // a reader missed is an error reply, not a crash.
    ParseResult r;
    r.error = {ErrorCode::kBadJson, bounded("request not readable: " + withoutTag(e.what()))};
    return r;
  }
}

Reply okReply(json id, json result) {
  Reply r;
  r.id = std::move(id);
  r.result = std::move(result);
  return r;
}

Reply errorReply(json id, ErrorCode code, std::string message) {
  Reply r;
  r.id = std::move(id);
  r.ok = false;
  r.error = {code, std::move(message)};
  return r;
}

namespace {
std::string dumpLine(const json& j) {
  // replace, not throw: error messages may quote the client's invalid UTF-8.
  return j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
}
}  // namespace

std::string serializeReply(const Reply& reply) {
  json j = {{"id", reply.id}, {"ok", reply.ok}};
  if (reply.ok)
    j["result"] = reply.result;
  else
    j["error"] = {{"code", errorCodeName(reply.error.code)}, {"message", reply.error.message}};
  return dumpLine(j);
}

std::string serializeEvent(Topic topic, std::string_view name, const json& fields) {
  json j = json::object();
  if (fields.is_object()) j = fields;
  j["event"] = name;
  j["topic"] = topicName(topic);
  return dumpLine(j);
}

}  // namespace imubench::daemon
