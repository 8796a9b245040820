#include "daemon/control_protocol.h"

#include <algorithm>
#include <array>
#include <initializer_list>
#include <limits>
#include <utility>

#include "daemon/control_protocol_internal.h"
#include "io/enum_names.h"

namespace imubench::daemon {

using nlohmann::json;

using control_protocol_internal::kCommands;
using control_protocol_internal::kMaxQuotedBytes;
using control_protocol_internal::kTopics;
using control_protocol_internal::parseErrorReason;
using control_protocol_internal::readArgs;
using control_protocol_internal::readCommandName;
using control_protocol_internal::readId;

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
      if (escaped) {
        escaped = false;
      } else if (ch == '\\') {
        escaped = true;
      } else if (ch == '"') {
        in_string = false;
      }
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
  if (reply.ok) {
    j["result"] = reply.result;
  } else {
    j["error"] = {{"code", errorCodeName(reply.error.code)}, {"message", reply.error.message}};
  }
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
