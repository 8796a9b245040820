// Internals shared by the parts of the control protocol (daemon/control_protocol.h): the
// command and topic names, and the request readers that parseRequest calls. Not a public API:
// only daemon/control_protocol.cpp and daemon/control_protocol_args.cpp include it.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

#include "daemon/control_protocol.h"
#include "io/enum_names.h"

namespace imubench::daemon::control_protocol_internal {

inline constexpr std::array<io::Named<Command, std::string_view>, 19> kCommands{{
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

inline constexpr std::array<io::Named<Topic, std::string_view>, kTopicCount> kTopics{{
    {Topic::kRun, "run"},
    {Topic::kStatus, "status"},
    {Topic::kLog, "log"},
}};

// Bytes of a client's text quoted in an error message: replies stay small whatever was sent.
inline constexpr std::size_t kMaxQuotedBytes = 80;

// The request's id: a string or an integer (JSON-RPC's choice, minus fractions), echoed as is.
bool readId(const nlohmann::json& obj, nlohmann::json* id, ProtocolError* err);

// The command a request names ("cmd"); unknown_command lists the known ones.
bool readCommandName(const nlohmann::json& obj, Command* out, ProtocolError* err);

// The arguments of one command; refuses fields the command does not take.
bool readArgs(const nlohmann::json& obj, Command c, RequestArgs* out, ProtocolError* err);

// nlohmann's what() is "[json.exception.parse_error.101] parse error at line 1, column 5:
// syntax error while parsing value - ...": keep the reason, the byte offset says where.
std::string parseErrorReason(const nlohmann::json::parse_error& e);

}  // namespace imubench::daemon::control_protocol_internal
