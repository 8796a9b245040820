// The control protocol's request readers: each command's arguments, checked field by field
// (daemon/control_protocol.h; the grammar is described in daemon/control_protocol.cpp).

#include <algorithm>
#include <cstddef>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "daemon/control_protocol.h"
#include "daemon/control_protocol_internal.h"
#include "io/enum_names.h"

namespace imubench::daemon {

using control_protocol_internal::kCommands;
using control_protocol_internal::kMaxQuotedBytes;
using control_protocol_internal::kTopics;
using nlohmann::json;

namespace {

// Labels end up in the run history and in every status reply: bounded so they stay readable.
constexpr std::size_t kMaxLabelBytes = 200;
// A plan's diagnostic name (its file path on the client) and an export's directory name:
// bounded like a path component or a path, so they stay readable in replies and logs.
constexpr std::size_t kMaxPlanNameBytes = 4096;
constexpr std::size_t kMaxExportNameBytes = 255;

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
  if (!it->is_string()) {
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be a string, got " + it->type_name());
  }
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
  if (obj.contains(key) && out->front() != '/') {
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be an absolute path, got " + quote(*out));
  }
  return true;
}

bool readBool(const json& obj, std::string_view key, std::string_view where, bool* out,
              ProtocolError* err) {
  const auto it = obj.find(key);
  if (it == obj.end()) return true;
  if (!it->is_boolean()) {
    return fail(err, ErrorCode::kBadArgument,
                joinPath(where, key) + ": must be true or false, got " + it->type_name());
  }
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
  if (!it->is_number_integer()) {
    return fail(err, ErrorCode::kBadArgument,
                where + ": must be an integer " + std::string(noun) + ", got " + shown(*it));
  }
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
  if (!it->is_object()) {
    return fail(err, ErrorCode::kBadArgument,
                std::string("plan: must be an object {\"path\":...} or {\"toml\":...}, got ") +
                    it->type_name());
  }
  if (!refuseUnknownFields(*it, {"path", "toml", "name"}, "plan", "plan", err)) return false;
  const bool has_path = it->contains("path");
  if (has_path == it->contains("toml"))
    return fail(err, ErrorCode::kBadArgument, "plan: needs exactly one of \"path\" or \"toml\"");
  out->kind = has_path ? PlanSource::Kind::kPath : PlanSource::Kind::kInline;
  if (has_path) {
    if (it->contains("name")) {
      return fail(err, ErrorCode::kBadArgument,
                  "plan.name: only with \"toml\" (a path names the plan itself)");
    }
    return readAbsolutePath(*it, "path", "plan", true, &out->text, err);
  }
  if (!readNonEmptyString(*it, "name", "plan", false, &out->name, err)) return false;
  if (out->name.size() > kMaxPlanNameBytes) {
    return fail(err, ErrorCode::kBadArgument,
                "plan.name: longer than " + std::to_string(kMaxPlanNameBytes) + " bytes");
  }
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
  if (!it->is_object()) {
    return fail(err, ErrorCode::kBadArgument,
                std::string("options: must be an object, got ") + it->type_name());
  }
  if (!refuseUnknownFields(*it, {"dry_run", "label", "out_dir", "queue"}, "options", "options",
                           err))
    return false;
  if (!readBool(*it, "dry_run", "options", &out->dry_run, err)) return false;
  if (!readBool(*it, "queue", "options", &out->queue, err)) return false;
  if (out->queue && out->dry_run) {
    return fail(err, ErrorCode::kBadArgument,
                "options.queue: not with dry_run (a dry run only validates; use validate_plan)");
  }
  if (!readString(*it, "label", "options", false, &out->label, err)) return false;
  if (out->label.size() > kMaxLabelBytes) {
    return fail(err, ErrorCode::kBadArgument,
                "options.label: longer than " + std::to_string(kMaxLabelBytes) + " bytes");
  }
  return readAbsolutePath(*it, "out_dir", "options", false, &out->out_dir, err);
}

bool readTopics(const json& obj, bool required, std::vector<Topic>* out, ProtocolError* err) {
  const auto it = obj.find("topics");
  if (it == obj.end()) {
    if (required) return fail(err, ErrorCode::kBadArgument, "topics: missing");
    return true;
  }
  if (!it->is_array() || it->empty()) {
    return fail(err, ErrorCode::kBadArgument,
                "topics: must be a non-empty array of topic names (" + topicList() + ")");
  }
  for (std::size_t i = 0; i < it->size(); ++i) {
    const std::string where = "topics[" + std::to_string(i) + "]";
    const json& v = (*it)[i];
    if (!v.is_string())
      return fail(err, ErrorCode::kBadArgument, where + ": must be a string, got " + v.type_name());
    const auto topic = topicFromName(v.get<std::string>());
    if (!topic) {
      return fail(err, ErrorCode::kBadArgument,
                  where + ": unknown topic " + quote(v.get<std::string>()) +
                      " (known: " + topicList() + ")");
    }
    if (std::find(out->begin(), out->end(), *topic) != out->end()) {
      return fail(err, ErrorCode::kBadArgument,
                  where + ": duplicate topic " + quote(topicName(*topic)));
    }
    out->push_back(*topic);
  }
  return true;
}

}  // namespace

namespace control_protocol_internal {

// The request's id: a string or an integer (JSON-RPC's choice, minus fractions), echoed as is.
bool readId(const json& obj, json* id, ProtocolError* err) {
  const auto it = obj.find("id");
  if (it == obj.end()) return true;
  if (!it->is_string() && !it->is_number_integer()) {
    return fail(err, ErrorCode::kBadArgument,
                std::string("id: must be a string or an integer, got ") + it->type_name());
  }
  *id = *it;
  return true;
}

bool readCommandName(const json& obj, Command* out, ProtocolError* err) {
  const auto it = obj.find("cmd");
  if (it == obj.end()) return fail(err, ErrorCode::kBadArgument, "cmd: missing");
  if (!it->is_string()) {
    return fail(err, ErrorCode::kBadArgument,
                std::string("cmd: must be a string, got ") + it->type_name());
  }
  const std::string name = it->get<std::string>();
  if (const auto c = io::valueOf(kCommands, name)) {
    *out = *c;
    return true;
  }
  return fail(err, ErrorCode::kUnknownCommand,
              "cmd: unknown command " + quote(name) + " (known: " + commandList() + ")");
}

}  // namespace control_protocol_internal

namespace {

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

}  // namespace

namespace control_protocol_internal {

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
      if (c == Command::kSubscribe) {
        *out = SubscribeArgs{std::move(topics)};
      } else {
        *out = UnsubscribeArgs{std::move(topics)};
      }
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

}  // namespace control_protocol_internal

}  // namespace imubench::daemon
