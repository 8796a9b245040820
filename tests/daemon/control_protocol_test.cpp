// The control protocol's parser: every command, every error kind, and a property test over
// random and mutated lines (never throws, every refusal says where and why, every reply
// serializes to one valid JSON line).
#include "daemon/control_protocol.h"

#include <gtest/gtest.h>

#include <random>
#include <span>
#include <string>

namespace imubench::daemon {
namespace {

using nlohmann::json;

Request parseOk(const std::string& line) {
  const ParseResult r = parseRequest(line);
  EXPECT_TRUE(r.ok) << line << " -> " << r.error.message;
  return r.request;
}

ProtocolError parseErr(const std::string& line, ErrorCode code) {
  const ParseResult r = parseRequest(line);
  EXPECT_FALSE(r.ok) << line;
  EXPECT_EQ(errorCodeName(r.error.code), errorCodeName(code)) << line << " -> " << r.error.message;
  EXPECT_FALSE(r.error.message.empty());
  return r.error;
}

// Each request line is refused with bad_argument, its message holding the reason paired with it.
using BadArgument = std::pair<const char*, const char*>;
void expectBadArguments(std::span<const BadArgument> cases) {
  for (const auto& [line, want] : cases) {
    const ProtocolError e = parseErr(line, ErrorCode::kBadArgument);
    EXPECT_NE(e.message.find(want), std::string::npos) << line << " -> " << e.message;
  }
}

TEST(ControlProtocol, CommandsWithoutArguments) {
  const std::pair<const char*, Command> cases[] = {
      {"pause", Command::kPause},   {"abort", Command::kAbort},          {"stop", Command::kStop},
      {"status", Command::kStatus}, {"list_plans", Command::kListPlans}, {"ping", Command::kPing},
      {"rearm", Command::kRearm}};
  for (const auto& [name, cmd] : cases) {
    const Request r = parseOk(std::string("{\"id\":3,\"cmd\":\"") + name + "\"}");
    EXPECT_EQ(r.command, cmd);
    EXPECT_EQ(r.id, json(3));
    EXPECT_TRUE(std::holds_alternative<NoArgs>(r.args));
    EXPECT_EQ(commandName(cmd), name);
    // The same command refuses any argument, naming it.
    const ProtocolError e =
        parseErr(std::string("{\"cmd\":\"") + name + "\",\"force\":true}", ErrorCode::kBadArgument);
    EXPECT_NE(e.message.find("force: unknown field of command"), std::string::npos) << e.message;
  }
}

// resume: the paused run (no argument), or an interrupted run by id.
TEST(ControlProtocol, ResumeThePausedRunOrAnInterruptedOne) {
  Request r = parseOk(R"({"id":1,"cmd":"resume"})");
  EXPECT_EQ(r.command, Command::kResume);
  ASSERT_TRUE(std::holds_alternative<ResumeArgs>(r.args));
  EXPECT_FALSE(std::get<ResumeArgs>(r.args).run);
  r = parseOk(R"({"id":2,"cmd":"resume","run":42})");
  ASSERT_TRUE(std::holds_alternative<ResumeArgs>(r.args));
  EXPECT_EQ(std::get<ResumeArgs>(r.args).run, 42);
  for (const char* bad : {R"({"cmd":"resume","run":0})", R"({"cmd":"resume","run":"x"})",
                          R"({"cmd":"resume","force":true})"}) {
    parseErr(bad, ErrorCode::kBadArgument);
  }
}

TEST(ControlProtocol, IdIsOptionalStringOrInteger) {
  EXPECT_TRUE(parseOk(R"({"cmd":"ping"})").id.is_null());
  EXPECT_EQ(parseOk(R"({"cmd":"ping","id":"abc"})").id, json("abc"));
  EXPECT_EQ(parseOk(R"({"cmd":"ping","id":-5})").id, json(-5));
  for (const char* bad : {R"({"cmd":"ping","id":1.5})", R"({"cmd":"ping","id":null})",
                          R"({"cmd":"ping","id":[1]})", R"({"cmd":"ping","id":true})"}) {
    const ProtocolError e = parseErr(bad, ErrorCode::kBadArgument);
    EXPECT_EQ(e.message.rfind("id: must be a string or an integer", 0), 0u) << e.message;
  }
}

TEST(ControlProtocol, StartWithPathOrInlinePlanAndOptions) {
  Request r = parseOk(R"({"id":"a","cmd":"start","plan":{"path":"/etc/imubench/p.toml"}})");
  ASSERT_EQ(r.command, Command::kStart);
  const auto& a = std::get<StartArgs>(r.args);
  EXPECT_EQ(a.plan.kind, PlanSource::Kind::kPath);
  EXPECT_EQ(a.plan.text, "/etc/imubench/p.toml");
  EXPECT_FALSE(a.options.dry_run);

  r = parseOk(R"({"cmd":"start","plan":{"toml":"[plan]\nname = \"x\"\n"},)"
              R"("options":{"dry_run":true,"label":"unit 42","out_dir":"/srv/runs"}})");
  const auto& b = std::get<StartArgs>(r.args);
  EXPECT_EQ(b.plan.kind, PlanSource::Kind::kInline);
  EXPECT_EQ(b.plan.text, "[plan]\nname = \"x\"\n");
  EXPECT_TRUE(b.options.dry_run);
  EXPECT_EQ(b.options.label, "unit 42");
  EXPECT_EQ(b.options.out_dir, "/srv/runs");
  EXPECT_EQ(b.plan.name, "");

  // The client's file name for diagnostics travels with the text; a path names itself.
  r = parseOk(R"({"cmd":"validate_plan","plan":{"toml":"x","name":"/home/op/p.toml"}})");
  EXPECT_EQ(std::get<ValidatePlanArgs>(r.args).plan.name, "/home/op/p.toml");
  EXPECT_NE(
      parseErr(R"({"cmd":"start","plan":{"path":"/p.toml","name":"x"}})", ErrorCode::kBadArgument)
          .message.find("plan.name: only with \"toml\""),
      std::string::npos);
  EXPECT_NE(parseErr(R"({"cmd":"start","plan":{"toml":"x","name":3}})", ErrorCode::kBadArgument)
                .message.find("plan.name: must be a string"),
            std::string::npos);
}

TEST(ControlProtocol, StartArgumentErrorsNameTheField) {
  const BadArgument cases[] = {
      {R"({"cmd":"start"})", "plan: missing"},
      {R"({"cmd":"start","plan":"/p.toml"})", "plan: must be an object"},
      {R"({"cmd":"start","plan":{}})", "plan: needs exactly one of"},
      {R"({"cmd":"start","plan":{"path":"/a","toml":"x"}})", "plan: needs exactly one of"},
      {R"({"cmd":"start","plan":{"path":"rel/p.toml"}})", "plan.path: must be an absolute path"},
      {R"({"cmd":"start","plan":{"path":""}})", "plan.path: must not be empty"},
      {R"({"cmd":"start","plan":{"path":"/a\u0000b"}})", "plan.path: contains a NUL byte"},
      {R"({"cmd":"start","plan":{"path":7}})", "plan.path: must be a string, got number"},
      {R"({"cmd":"start","plan":{"toml":""}})", "plan.toml: must not be empty"},
      {R"({"cmd":"start","plan":{"path":"/a","url":"x"}})", "plan.url: unknown field"},
      {R"({"cmd":"start","plan":{"path":"/a"},"options":[]})", "options: must be an object"},
      {R"({"cmd":"start","plan":{"path":"/a"},"options":{"dry_run":1}})",
       "options.dry_run: must be true or false"},
      {R"({"cmd":"start","plan":{"path":"/a"},"options":{"label":3}})",
       "options.label: must be a string"},
      {R"({"cmd":"start","plan":{"path":"/a"},"options":{"out_dir":"x"}})",
       "options.out_dir: must be an absolute path"},
      {R"({"cmd":"start","plan":{"path":"/a"},"options":{"speed":2}})",
       "options.speed: unknown field"},
      {R"({"cmd":"start","plan":{"path":"/a"},"run":2})", "run: unknown field of command"},
  };
  expectBadArguments(cases);
  const std::string long_label = R"({"cmd":"start","plan":{"path":"/a"},"options":{"label":")" +
                                 std::string(201, 'x') + "\"}}";
  EXPECT_NE(parseErr(long_label, ErrorCode::kBadArgument).message.find("options.label: longer"),
            std::string::npos);
}

// Issue 15: the plan queue's requests.
TEST(ControlProtocol, QueueCommands) {
  Request r =
      parseOk(R"({"cmd":"start","plan":{"toml":"x"},"options":{"queue":true,"label":"u"}})");
  EXPECT_TRUE(std::get<StartArgs>(r.args).options.queue);
  EXPECT_FALSE(
      std::get<StartArgs>(parseOk(R"({"cmd":"start","plan":{"toml":"x"}})").args).options.queue);
  r = parseOk(R"({"id":1,"cmd":"queue_move","entry":7,"position":2})");
  EXPECT_EQ(r.command, Command::kQueueMove);
  EXPECT_EQ(std::get<QueueMoveArgs>(r.args).entry, 7);
  EXPECT_EQ(std::get<QueueMoveArgs>(r.args).position, 2);
  r = parseOk(R"({"cmd":"queue_remove","entry":3})");
  EXPECT_EQ(std::get<QueueRemoveArgs>(r.args).entry, 3);
  r = parseOk(R"({"cmd":"queue_accept","run":41})");
  EXPECT_EQ(r.command, Command::kQueueAccept);
  EXPECT_EQ(std::get<QueueAcceptArgs>(r.args).run, 41);
  for (const auto& [name, cmd] : {std::pair{"queue_list", Command::kQueueList},
                                  std::pair{"queue_resume", Command::kQueueResume}}) {
    r = parseOk(std::string("{\"cmd\":\"") + name + "\"}");
    EXPECT_EQ(r.command, cmd);
    EXPECT_EQ(commandName(cmd), name);
  }
  const BadArgument cases[] = {
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"queue":true,"dry_run":true}})",
       "options.queue: not with dry_run"},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"queue":"yes"}})",
       "options.queue: must be true or false"},
      {R"({"cmd":"queue_move","entry":7})", "position: missing"},
      {R"({"cmd":"queue_move","position":1})", "entry: missing"},
      {R"({"cmd":"queue_move","entry":7,"position":0})", "position: must be >= 1"},
      {R"({"cmd":"queue_move","entry":7,"position":1.5})",
       "position: must be an integer position (1 = next), got 1.5"},
      {R"({"cmd":"queue_move","entry":7,"position":99999999999})", "position: out of range"},
      {R"({"cmd":"queue_remove","entry":"3"})", "entry: must be an integer queue entry id"},
      {R"({"cmd":"queue_remove","entry":3,"position":1})", "position: unknown field of command"},
      {R"({"cmd":"queue_list","entry":3})", "entry: unknown field of command"},
      {R"({"cmd":"queue_accept"})", "run: missing"},
      {R"({"cmd":"queue_accept","run":2,"entry":3})", "entry: unknown field of command"},
  };
  expectBadArguments(cases);
}

TEST(ControlProtocol, SubscribeAndUnsubscribe) {
  Request r = parseOk(R"({"cmd":"subscribe","topics":["run","log"]})");
  EXPECT_EQ(std::get<SubscribeArgs>(r.args).topics, (std::vector<Topic>{Topic::kRun, Topic::kLog}));
  r = parseOk(R"({"cmd":"unsubscribe"})");
  EXPECT_TRUE(std::get<UnsubscribeArgs>(r.args).topics.empty());
  r = parseOk(R"({"cmd":"unsubscribe","topics":["status"]})");
  EXPECT_EQ(std::get<UnsubscribeArgs>(r.args).topics, std::vector<Topic>{Topic::kStatus});
  const BadArgument cases[] = {
      {R"({"cmd":"subscribe"})", "topics: missing"},
      {R"({"cmd":"subscribe","topics":[]})", "topics: must be a non-empty array"},
      {R"({"cmd":"subscribe","topics":"run"})", "topics: must be a non-empty array"},
      {R"({"cmd":"subscribe","topics":["run",3]})", "topics[1]: must be a string"},
      {R"({"cmd":"subscribe","topics":["weather"]})", "topics[0]: unknown topic \"weather\""},
      {R"({"cmd":"subscribe","topics":["run","run"]})", "topics[1]: duplicate topic"},
      {R"({"cmd":"unsubscribe","topics":[]})", "topics: must be a non-empty array"},
  };
  expectBadArguments(cases);
}

TEST(ControlProtocol, ValidatePlanResultsExport) {
  Request r = parseOk(R"({"cmd":"validate_plan","plan":{"toml":"x"}})");
  EXPECT_EQ(std::get<ValidatePlanArgs>(r.args).plan.kind, PlanSource::Kind::kInline);
  EXPECT_FALSE(std::get<ResultsArgs>(parseOk(R"({"cmd":"results"})").args).run.has_value());
  EXPECT_EQ(std::get<ResultsArgs>(parseOk(R"({"cmd":"results","run":42})").args).run, 42);
  // Issue 17: an export names a directory under the daemon's export directory, not a path.
  r = parseOk(R"({"cmd":"export","run":7,"dir":"unit-42_b.1"})");
  EXPECT_EQ(std::get<ExportArgs>(r.args).run, 7);
  EXPECT_EQ(std::get<ExportArgs>(r.args).dir, "unit-42_b.1");
  EXPECT_EQ(std::get<ExportArgs>(parseOk(R"({"cmd":"export","run":7})").args).dir, "");
  const BadArgument cases[] = {
      {R"({"cmd":"validate_plan"})", "plan: missing"},
      {R"({"cmd":"results","run":1.0})", "run: must be an integer run id, got 1.0"},
      {R"({"cmd":"results","run":"3"})", "run: must be an integer run id"},
      {R"({"cmd":"results","run":0})", "run: must be >= 1"},
      {R"({"cmd":"results","run":18446744073709551615})", "run: out of range"},
      {R"({"cmd":"export","dir":"/x"})", "run: missing"},
      {R"({"cmd":"export","run":1,"dir":"/srv/x"})", "dir: must be a single name"},
      {R"({"cmd":"export","run":1,"dir":"a/b"})", "dir: must be a single name"},
      {R"({"cmd":"export","run":1,"dir":".."})", "dir: must not start with '.'"},
      {R"({"cmd":"export","run":1,"dir":""})", "dir: must not be empty"},
      {R"({"cmd":"export","run":1,"dir":"x","format":"csv"})", "format: unknown field"},
  };
  expectBadArguments(cases);
}

TEST(ControlProtocol, BadJsonSaysWhichByte) {
  const ProtocolError e = parseErr(R"({"cmd":"ping")", ErrorCode::kBadJson);
  EXPECT_EQ(e.message.rfind("byte 14: ", 0), 0u) << e.message;
  EXPECT_EQ(parseErr("", ErrorCode::kBadJson).message.rfind("byte ", 0), 0u);
  EXPECT_EQ(parseErr("{\"cmd\":\"\xff\"}", ErrorCode::kBadJson).message.rfind("byte 9: ", 0), 0u);
  // Valid JSON of the wrong shape is an argument error, not a JSON error.
  EXPECT_NE(parseErr("[1,2]", ErrorCode::kBadArgument).message.find("must be a JSON object"),
            std::string::npos);
}

TEST(ControlProtocol, CommandErrors) {
  EXPECT_NE(parseErr(R"({"id":1})", ErrorCode::kBadArgument).message.find("cmd: missing"),
            std::string::npos);
  EXPECT_NE(parseErr(R"({"cmd":5})", ErrorCode::kBadArgument).message.find("cmd: must be a string"),
            std::string::npos);
  const ParseResult r = parseRequest(R"({"id":9,"cmd":"fly"})");
  EXPECT_EQ(r.error.code, ErrorCode::kUnknownCommand);
  EXPECT_EQ(r.id, json(9));  // echoed even on errors
  EXPECT_NE(r.error.message.find("unknown command \"fly\" (known: start, "), std::string::npos);
}

TEST(ControlProtocol, RepliesAndEventsAreSingleJsonLines) {
  EXPECT_EQ(serializeReply(okReply(1, {{"state", "idle"}})),
            "{\"id\":1,\"ok\":true,\"result\":{\"state\":\"idle\"}}\n");
  EXPECT_EQ(
      serializeReply(errorReply("x", ErrorCode::kBusy, "a run is going")),
      "{\"error\":{\"code\":\"busy\",\"message\":\"a run is going\"},\"id\":\"x\",\"ok\":false}\n");
  EXPECT_EQ(serializeEvent(Topic::kRun, "step_started", {{"step", 3}}),
            "{\"event\":\"step_started\",\"step\":3,\"topic\":\"run\"}\n");
  EXPECT_EQ(serializeEvent(Topic::kLog, "log"), "{\"event\":\"log\",\"topic\":\"log\"}\n");
  // Invalid UTF-8 in a message is replaced, not thrown.
  const std::string line = serializeReply(errorReply(nullptr, ErrorCode::kBadJson, "\xff\xfe"));
  EXPECT_TRUE(json::accept(line));
  for (const ErrorCode c :
       {ErrorCode::kBadJson, ErrorCode::kUnknownCommand, ErrorCode::kBadArgument,
        ErrorCode::kTooLarge, ErrorCode::kBusy, ErrorCode::kBadState, ErrorCode::kNotFound,
        ErrorCode::kBadPlan, ErrorCode::kInternal})
    EXPECT_NE(errorCodeName(c), "");
}

// Property: for any input the parser returns (never throws); a refusal has a message; its
// error reply is one valid JSON line.
TEST(ControlProtocol, RandomAndMutatedLinesNeverThrow) {
  std::mt19937 rng(20240611);
  const std::string valid[] = {
      R"({"id":1,"cmd":"start","plan":{"path":"/p.toml"},"options":{"dry_run":true}})",
      R"({"id":"q","cmd":"subscribe","topics":["run","status"]})",
      R"({"cmd":"export","run":3,"dir":"e"})", R"({"cmd":"results","run":1})"};
  int accepted = 0;
  for (int i = 0; i < 20000; ++i) {
    std::string line;
    if (i % 2 == 0) {
      line.resize(rng() % 64);
      for (char& ch : line) ch = static_cast<char>(rng() % 256);
    } else {
      line = valid[rng() % 4];
      for (int m = 0, n = 1 + static_cast<int>(rng() % 4); m < n; ++m)
        line[rng() % line.size()] = static_cast<char>(rng() % 256);
    }
    ParseResult r;
    ASSERT_NO_THROW(r = parseRequest(line)) << i;
    if (r.ok) {
      ++accepted;
      continue;
    }
    EXPECT_FALSE(r.error.message.empty());
    const std::string reply = serializeReply(errorReply(r.id, r.error.code, r.error.message));
    ASSERT_TRUE(json::accept(reply.substr(0, reply.size() - 1))) << reply;
    ASSERT_EQ(reply.find('\n'), reply.size() - 1);
  }
  EXPECT_GT(accepted, 0);  // some mutations stay valid (e.g. inside a string)
}

// ---- hostile input (issue 28 item 1): every class is an error reply, nothing throws ----

// Numbers no double holds: `{"cmd":"ping","id":1e400}` killed imubenchd (nlohmann's
// out_of_range.406 escaped the parser). Each is bad_json naming the number, wherever it is.
TEST(ControlProtocolHostile, NumbersOutOfRangeAreErrors) {
  const std::string huge_integer(400, '9');
  for (const std::string& number : {std::string("1e400"), std::string("-1e400"),
                                    std::string("1E+999"), huge_integer, "-" + huge_integer}) {
    for (const std::string& line :
         {R"({"cmd":"ping","id":)" + number + "}", R"({"cmd":"results","run":)" + number + "}",
          R"({"cmd":"queue_move","entry":1,"position":)" + number + "}",
          R"({"cmd":"ping","x":[)" + number + "]}", number}) {
      ParseResult r;
      ASSERT_NO_THROW(r = parseRequest(line)) << line;
      EXPECT_FALSE(r.ok) << line;
      EXPECT_EQ(errorCodeName(r.error.code), "bad_json") << line << " -> " << r.error.message;
      EXPECT_NE(r.error.message.find("number out of range"), std::string::npos) << r.error.message;
      EXPECT_LT(r.error.message.size(), 600u) << "the message quotes a bounded part of the line";
    }
  }
  // In range but not integers, or beyond int64: refused as arguments, not as JSON.
  parseErr(R"({"cmd":"ping","id":1e300})", ErrorCode::kBadArgument);
  parseErr(R"({"cmd":"results","run":18446744073709551615})", ErrorCode::kBadArgument);
  parseErr(R"({"cmd":"results","run":18446744073709551616})", ErrorCode::kBadArgument);
  parseErr(R"({"cmd":"results","run":-9223372036854775808})", ErrorCode::kBadArgument);
  parseErr(R"({"cmd":"queue_move","entry":1,"position":4294967296})", ErrorCode::kBadArgument);
  // Underflow is 0.0: a number, but not an integer id.
  parseErr(R"({"cmd":"ping","id":1e-400})", ErrorCode::kBadArgument);
}

// Deep nesting: refused before nlohmann builds (and would recurse through) the value.
TEST(ControlProtocolHostile, DeepNestingIsRefused) {
  for (const std::size_t depth : {33u, 1000u, 60000u}) {
    for (const auto& [open, close] : {std::pair{'[', ']'}, std::pair{'{', '}'}}) {
      std::string deep;
      if (open == '{') {
        for (std::size_t i = 0; i < depth; ++i) deep += "{\"a\":";
        deep += "1" + std::string(depth, close);
      } else {
        deep = std::string(depth, open) + std::string(depth, close);
      }
      for (const std::string& line :
           {deep, R"({"cmd":"results","run":)" + deep + "}", R"({"cmd":"ping","id":)" + deep + "}",
            std::string(depth, open)}) {
        const ProtocolError e = parseErr(line, ErrorCode::kBadJson);
        EXPECT_NE(e.message.find("nested more than 32 deep"), std::string::npos) << e.message;
      }
    }
  }
  // Brackets inside strings are text, and 32 levels are still JSON (refused for other reasons).
  EXPECT_EQ(
      parseOk(R"({"cmd":"start","plan":{"toml":")" + std::string(100, '[') + R"("}})").command,
      Command::kStart);
  const std::string levels32 = std::string(31, '[') + std::string(31, ']');
  parseErr(R"({"cmd":"ping","x":)" + levels32 + "}", ErrorCode::kBadArgument);
}

// Every field of every command with every JSON type it does not take.
TEST(ControlProtocolHostile, OddTypesForEveryFieldAreBadArguments) {
  const std::string odd[] = {"null",  "true", "0",   "-1", "1.5",
                             "\"x\"", "[]",   "[1]", "{}", R"({"a":[1,{"b":null}]})"};
  // field -> the values it takes (the rest must be refused).
  const std::pair<std::string, std::string> fields[] = {
      {R"({"cmd":"ping","id":@})", "0 -1 \"x\""},
      {R"({"cmd":@})", ""},
      {R"({"cmd":"results","run":@})", ""},
      {R"({"cmd":"export","run":@})", ""},
      {R"({"cmd":"export","run":1,"dir":@})", "\"x\""},
      {R"({"cmd":"resume","run":@})", ""},
      {R"({"cmd":"queue_remove","entry":@})", ""},
      {R"({"cmd":"queue_move","entry":1,"position":@})", ""},
      {R"({"cmd":"subscribe","topics":@})", ""},
      {R"({"cmd":"subscribe","topics":[@]})", ""},
      {R"({"cmd":"start","plan":@})", ""},
      {R"({"cmd":"start","plan":{"toml":@}})", "\"x\""},
      {R"({"cmd":"start","plan":{"path":@}})", ""},
      {R"({"cmd":"start","plan":{"toml":"x","name":@}})", "\"x\""},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":@})", "{}"},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"dry_run":@}})", "true"},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"queue":@}})", "true"},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"label":@}})", "\"x\""},
      {R"({"cmd":"start","plan":{"toml":"x"},"options":{"out_dir":@}})", ""},
      {R"({"cmd":"validate_plan","plan":@})", ""},
  };
  for (const auto& [pattern, takes] : fields) {
    for (const std::string& v : odd) {
      std::string line = pattern;
      line.replace(line.find('@'), 1, v);
      ParseResult r;
      ASSERT_NO_THROW(r = parseRequest(line)) << line;
      const bool taken = (" " + takes + " ").find(" " + v + " ") != std::string::npos;
      EXPECT_EQ(r.ok, taken) << line << " -> " << r.error.message;
      if (!r.ok) {
        EXPECT_NE(r.error.code, ErrorCode::kBadJson) << line;
        EXPECT_NE(r.error.code, ErrorCode::kInternal) << line;
      }
    }
  }
}

// Big strings, invalid UTF-8, NUL bytes (raw and escaped), control characters: errors whose
// messages stay small and serialize to one valid JSON line.
TEST(ControlProtocolHostile, StringsOfEveryShapeAreAnsweredSmall) {
  const std::string big(60000, 'x');
  const std::string lines[] = {
      R"({"cmd":")" + big + R"("})",
      R"({"cmd":"ping",")" + big + R"(":1})",
      R"({"cmd":"export","run":1,"dir":")" + big + R"("})",
      R"({"cmd":"start","plan":{"path":"/)" + big + R"("}})",
      R"({"cmd":"start","plan":{"toml":"x"},"options":{"label":")" + big + R"("}})",
      R"({"cmd":"results","run":")" + big + R"("})",
      std::string("{\"cmd\":\"pi\xff\xfeng\"}"),
      std::string("{\"cmd\":\"ping\",\"id\":\"\xc3\x28\"}"),
      std::string("{\"cmd\":\"ping\",\"id\":\"\xed\xa0\x80\"}"),  // a UTF-16 surrogate
      std::string("{\"cmd\":\"ping\"\0}", 16),
      std::string("{\"cmd\":\"pi\0ng\"}", 15),
      R"({"cmd":"ping\u0000"})",
      R"({"cmd":"start","plan":{"toml":"a\u0000b"}})",
      R"({"cmd":"ping","id":"\ud800"})",
      "{\"cmd\":\"ping\",\"id\":\"a\tb\"}",
      std::string(1, '\0'),
      "\xef\xbb\xbf{\"cmd\":\"ping\"}",  // a byte-order mark
      "",
      "   ",
  };
  for (const std::string& line : lines) {
    ParseResult r;
    ASSERT_NO_THROW(r = parseRequest(line)) << line.substr(0, 40);
    if (r.ok) continue;  // (the BOM is accepted by nlohmann)
    EXPECT_LT(r.error.message.size(), 600u) << r.error.message.substr(0, 200);
    const std::string reply = serializeReply(errorReply(r.id, r.error.code, r.error.message));
    EXPECT_TRUE(json::accept(reply.substr(0, reply.size() - 1))) << reply.substr(0, 200);
    EXPECT_EQ(reply.find('\n'), reply.size() - 1);
  }
}

// A generated corpus (deterministic seed) of 10,000 lines through the real parser: mutations
// of valid requests, random bytes, deep nesting, numbers out of every range, odd types spliced
// into every field. Each line is a valid request or an error with a message whose reply is one
// JSON line; none throws.
std::string fuzzLine(std::mt19937_64& rng, int i);

TEST(ControlProtocolHostile, FuzzCorpusOfTenThousandLines) {
  std::mt19937_64 rng(0x1e400);
  int accepted = 0;
  int out_of_range = 0;
  int too_deep = 0;
  for (int i = 0; i < 10000; ++i) {
    const std::string line = fuzzLine(rng, i);
    ParseResult r;
    ASSERT_NO_THROW(r = parseRequest(line)) << "line " << i << ": " << line.substr(0, 200);
    if (r.ok) {
      ++accepted;
      continue;
    }
    ASSERT_FALSE(r.error.message.empty()) << line.substr(0, 200);
    out_of_range += r.error.message.find("number out of range") != std::string::npos;
    too_deep += r.error.message.find("nested more than") != std::string::npos;
    const std::string reply = serializeReply(errorReply(r.id, r.error.code, r.error.message));
    ASSERT_TRUE(json::accept(reply.substr(0, reply.size() - 1))) << reply.substr(0, 200);
    ASSERT_EQ(reply.find('\n'), reply.size() - 1);
  }
  EXPECT_GT(accepted, 20);  // mutations that stay valid (e.g. inside a string)
  EXPECT_GT(out_of_range, 500);
  EXPECT_GT(too_deep, 500);
}

std::string fuzzLine(std::mt19937_64& rng, int i) {
  static const std::string kValid[] = {
      R"({"id":1,"cmd":"start","plan":{"toml":"[plan]"},"options":{"dry_run":true,"label":"l"}})",
      R"({"id":"q","cmd":"subscribe","topics":["run","status"]})",
      R"({"cmd":"export","run":3,"dir":"e"})",
      R"({"cmd":"results","run":1})",
      R"({"id":7,"cmd":"queue_move","entry":2,"position":1})",
      R"({"cmd":"resume","run":42})",
      R"({"cmd":"stop"})",
      R"({"cmd":"ping","id":9})"};
  static const std::string kNumbers[] = {"1e400",    "-1e400",
                                         "1e309",    "2e-400",
                                         "1.7e308",  "-0",
                                         "0.0",      "18446744073709551616",
                                         "1E+99999", "123456789012345678901234567890e300"};
  auto pick = [&rng](std::size_t n) { return static_cast<std::size_t>(rng() % n); };
  std::string line = kValid[pick(std::size(kValid))];
  switch (i % 5) {
    case 0: {  // random bytes
      line.resize(pick(200));
      for (char& ch : line) ch = static_cast<char>(rng());
      break;
    }
    case 1:  // byte mutations of a valid request
      for (std::size_t m = 0, n = 1 + pick(6); m < n; ++m)
        line[pick(line.size())] = static_cast<char>(rng());
      break;
    case 2: {  // a value (often an out-of-range number) replacing one of the request's values
      std::string value = kNumbers[pick(std::size(kNumbers))];
      if (rng() % 4 == 0) value = "[" + value + "," + value + "]";
      const std::size_t colon = line.find(':', pick(line.size()));
      if (colon == std::string::npos) return "{\"cmd\":\"ping\",\"id\":" + value + "}";
      const std::size_t end = line.find_first_of(",}", colon + 1);
      line.replace(colon + 1, end - colon - 1, value);
      break;
    }
    case 3: {  // deep nesting, balanced or not, inside a request or alone
      const std::size_t depth = 33 + pick(20000);
      const char open = rng() % 2 ? '[' : '{';
      std::string deep(depth, open);
      if (open == '[' && rng() % 2) deep += std::string(depth, ']');
      line = rng() % 2 ? deep : R"({"cmd":"results","run":)" + deep + "}";
      break;
    }
    default: {  // a valid request with a few bytes inserted or deleted
      for (std::size_t m = 0, n = 1 + pick(3); m < n && !line.empty(); ++m) {
        const std::size_t at = pick(line.size());
        if (rng() % 2)
          line.insert(at, 1, "{}[]\",:\\0e-+"[pick(12)]);
        else
          line.erase(at, 1);
      }
      break;
    }
  }
  return line;
}

// ---- replies and events: build -> serialize -> parse -> equal, for every type ----

// A reply's result through the wire: okReply -> serializeReply -> JSON line -> fromJson.
template <class R>
void expectReplyRoundTrip(const R& result) {
  const std::string line = serializeReply(okReply(7, toJson(result)));
  const json j = json::parse(line);
  std::string why;
  const auto back = fromJson<R>(j["result"], &why);
  ASSERT_TRUE(back.has_value()) << why << " in " << line;
  EXPECT_TRUE(*back == result) << line;
}

// An event through the wire: serializeEvent -> JSON line -> parseEvent.
template <class E>
void expectEventRoundTrip(const E& event) {
  const std::string line = serializeEvent(event);
  const json j = json::parse(line);
  EXPECT_EQ(j["event"], std::string(E::kEvent));
  EXPECT_EQ(j["topic"], std::string(topicName(E::kTopic)));
  std::string why;
  const auto back = parseEvent<E>(j, &why);
  ASSERT_TRUE(back.has_value()) << why << " in " << line;
  EXPECT_TRUE(*back == event) << line;
}

TEST(ControlProtocol, EveryEventRoundTrips) {
  const StepRef at{12, 3, "run01_x_p1"};
  expectEventRoundTrip(RunStateEvent{at, "finished", "completed"});
  expectEventRoundTrip(RunStateEvent{at, "paused", std::nullopt});
  expectEventRoundTrip(StepStartedEvent{at});
  expectEventRoundTrip(StepFinishedEvent{at});
  expectEventRoundTrip(AlarmEvent{at, "chamber 0.4 degC over setpoint"});
  expectEventRoundTrip(ImuRestartEvent{2, "counter jumped 17 -> 3", 12});
  expectEventRoundTrip(ImuRestartEvent{1, "time stamp went back", std::nullopt});
  expectEventRoundTrip(RunFinishedEvent{12, "aborted", "aborted"});
  expectEventRoundTrip(QueuedEvent{5, 2, "thermal"});
  expectEventRoundTrip(QueueStartedEvent{5, 13, "thermal"});
  expectEventRoundTrip(QueueHeldEvent{"queue entry 5: interlock open"});
  expectEventRoundTrip(RearmedEvent{12});
  expectEventRoundTrip(ProgressEvent{12, "running", 0.25, 812.5, 3, "run01_x_p1"});
}

TEST(ControlProtocol, EveryReplyRoundTrips) {
  const PlanSummary plan{"two_axis_12run", 45, 1234.5};
  const TableStatus table{"closed",          false,        true,        "connected",
                          "timeout on read", std::nullopt, std::nullopt};
  expectReplyRoundTrip(PingReply{true});
  expectReplyRoundTrip(TopicsReply{{"run", "status"}});
  expectReplyRoundTrip(TopicsReply{});
  expectReplyRoundTrip(StartReply{12, plan, std::nullopt});
  expectReplyRoundTrip(StartReply{12, plan, 5});
  expectReplyRoundTrip(DryRunReply{true, plan});
  expectReplyRoundTrip(QueuedReply{QueuedEvent{5, 2, "thermal"}});
  expectReplyRoundTrip(StopReply{true});
  expectReplyRoundTrip(RunCommandReply{12, "paused"});
  expectReplyRoundTrip(RearmReply{table});
  expectReplyRoundTrip(RearmReply{TableStatus{"open", true, false, "connected", std::nullopt,
                                              std::vector<double>{12.5, -90.0}, true}});
  StatusReply idle{"bench-1",
                   "idle",
                   std::nullopt,
                   0,
                   0,
                   0,
                   table,
                   std::nullopt,
                   std::nullopt,
                   std::nullopt,
                   std::nullopt,
                   std::nullopt,
                   std::nullopt,
                   std::nullopt};
  expectReplyRoundTrip(idle);
  StatusReply running = idle;
  running.state = "running";
  running.imu_time_s = 123.25;
  running.imu_lost_samples = 4;
  running.imu_bad_frames = 1;
  running.imu_restarts = 2;
  running.queued = 3;
  running.run = 12;
  running.plan = "two_axis_12run";
  running.progress = 0.31;
  running.eta_s = 812.5;
  running.step = StatusStep{3, "run01_x_p1", "rotate", 45};
  running.lab = LabStatus{"fault",      "authentication", "password authentication failed", 42, 7,
                          std::nullopt, std::nullopt};
  expectReplyRoundTrip(running);
  running.lab->samples_backlog = 120000;  // [lab] mirror_samples
  running.lab->samples_shipped = 4000;
  expectReplyRoundTrip(running);
  expectReplyRoundTrip(PlanListReply{"/etc/imubench/plans", {"a.toml", "sub/b.toml"}});
  expectReplyRoundTrip(ValidatePlanReply{plan});
  expectReplyRoundTrip(RunListReply{{{12, "p", "finished", "completed", 1.7e9},
                                     {13, "q", "faulted", "emergency_stop", 1.7e9 + 60}}});
  expectReplyRoundTrip(RunListReply{});
  expectReplyRoundTrip(RunResultsReply{
      12, "finished", "completed", {{"direct", json{{"gyro", {1, 2, 3}}}}, {"bad", nullptr}}});
  expectReplyRoundTrip(ExportReply{12, "/var/lib/imubench/exports/run-12", 360000});
  expectReplyRoundTrip(QueueReply{{{5, 1, "thermal", "thermal.toml", "T=+20C", 1.7e9}}});
}

TEST(ControlProtocol, ReadersNameTheFieldAndIgnoreUnknownOnes) {
  std::string why;
  // A missing field, and a field of the wrong type, nested: named with its path.
  EXPECT_FALSE(fromJson<RunCommandReply>(json{{"state", "paused"}}, &why));
  EXPECT_EQ(why, "run: missing");
  json status = toJson(StatusReply{});
  status["step"] = {{"index", "three"}, {"label", "x"}, {"kind", "rotate"}, {"count", 4}};
  EXPECT_FALSE(fromJson<StatusReply>(status, &why));
  EXPECT_EQ(why, "step.index: must be an integer, got string");
  EXPECT_FALSE(fromJson<TopicsReply>(json{{"topics", {"run", 3}}}, &why));
  EXPECT_EQ(why, "topics[1]: must be a string, got number");
  EXPECT_FALSE(fromJson<PingReply>(json::array(), &why));
  // Another event's line is not this event.
  EXPECT_FALSE(parseEvent<AlarmEvent>(json::parse(serializeEvent(RearmedEvent{1})), &why));
  // A newer daemon's extra fields are ignored.
  json extra = toJson(RunCommandReply{12, "paused"});
  extra["since_unix_s"] = 1.7e9;
  const auto read = fromJson<RunCommandReply>(extra, &why);
  ASSERT_TRUE(read.has_value()) << why;
  EXPECT_EQ(read->run, 12);
}

}  // namespace
}  // namespace imubench::daemon
