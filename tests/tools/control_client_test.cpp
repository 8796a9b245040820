// tools/control_client.h and the control subcommands (tools/cli_control.cpp) against a fake
// imubenchd: the real ControlServer on an EventLoop thread with a handler returning canned
// replies and broadcasting run events, on a socket in a mkdtemp directory. A raw listener
// sends garbage or hangs up to check the client's errors. Every wait is a poll with a timeout.
#include "tools/control_client.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "daemon/control_server.h"
#include "daemon/event_loop.h"
#include "io/file_io.h"
#include "tests/daemon/control_test_util.h"
#include "tools/cli11.h"
#include "tools/cli_common.h"
#include "tools/cli_control.h"

namespace imubench::tools {
namespace {

using daemon::ClientId;
using daemon::Command;
using daemon::ControlServer;
using daemon::ControlServerOptions;
using daemon::ErrorCode;
using daemon::EventLoop;
using daemon::Reply;
using daemon::Request;
using daemon::Topic;
using daemon::testing::ScratchDir;
using nlohmann::json;

// A fake daemon: start -> run 12; the first status request of a running run is answered and
// then, on the loop's next turn, the run's events up to finished with the configured exit are
// broadcast; abort broadcasts a log event before its reply; pause when not running is
// bad_state; results know run 12 only.
class FakeDaemon {
 public:
  explicit FakeDaemon(const std::string& path, std::string exit = "completed")
      : exit_(std::move(exit)) {
    EXPECT_TRUE(loop_.open().ok);
    ControlServerOptions o;
    o.socket_path = path;
    server_ = std::make_unique<ControlServer>(
        &loop_, o, [this](const Request& r, ClientId c) { return handle(r, c); }, nullptr);
    start_ = server_->start();
    if (start_.ok) thread_ = std::thread([this] { loop_.run(); });
  }
  ~FakeDaemon() {
    if (thread_.joinable()) {
      loop_.stop();
      thread_.join();
    }
  }
  bool ok() const { return start_.ok; }
  std::vector<json> requests() {  // what the handler saw (read after the clients are done)
    std::vector<json> out;
    std::promise<void> done;
    loop_.post([&] {
      out = requests_;
      done.set_value();
    });
    done.get_future().wait_for(std::chrono::seconds(10));
    return out;
  }

 private:
  Reply handle(const Request& r, ClientId /*client*/) {
    json seen = {{"cmd", daemon::commandName(r.command)}};
    if (const auto* s = std::get_if<daemon::StartArgs>(&r.args)) {
      seen[s->plan.kind == daemon::PlanSource::Kind::kPath ? "path" : "toml"] = s->plan.text;
      if (!s->plan.name.empty()) seen["name"] = s->plan.name;
      seen["label"] = s->options.label;
      seen["dry_run"] = s->options.dry_run;
    }
    if (const auto* a = std::get_if<daemon::ResultsArgs>(&r.args)) {
      if (a->run) seen["run"] = *a->run;
    }
    requests_.push_back(seen);
    switch (r.command) {
      case Command::kStart:
        if (state_ == "running")
          return daemon::errorReply(r.id, ErrorCode::kBusy, "a run is going");
        state_ = "running";
        step_ = 0;
        played_ = false;
        return daemon::okReply(
            r.id, toJson(daemon::StartReply{12, {"two_axis_12run", 3, 812.5}, std::nullopt}));
      case Command::kStatus: {
        daemon::StatusReply st;
        st.bench = "fake";
        st.state = state_;
        st.table = {"closed", false, false, "connected", std::nullopt, std::nullopt, std::nullopt};
        if (state_ == "running") {
          st.run = 12;
          st.plan = "two_axis_12run";
          st.step = daemon::StatusStep{step_, "place_x_p1", "rotate", 3};
          st.progress = 0.0;
          st.eta_s = 812.5;
          // The run plays after this reply: a watcher that subscribed, then asked the status,
          // sees every event after it.
          if (!played_) loop_.post([this] { broadcastRun(); });
          played_ = true;
        }
        return daemon::okReply(r.id, toJson(st));
      }
      case Command::kPause:
        if (state_ != "running") {
          return daemon::errorReply(r.id, ErrorCode::kBadState,
                                    "not running (state " + state_ + ")");
        }
        state_ = "paused";
        return daemon::okReply(r.id, toJson(daemon::RunCommandReply{12, "paused"}));
      case Command::kResults: {
        const auto& a = std::get<daemon::ResultsArgs>(r.args);
        if (!a.run) return daemon::okReply(r.id, {{"runs", {{{"id", 12}, {"state", "finished"}}}}});
        if (*a.run != 12) return daemon::errorReply(r.id, ErrorCode::kNotFound, "no run 99");
        return daemon::okReply(r.id, {{"run", 12}, {"gyro.bias.x", 1.5e-5}});
      }
      case Command::kAbort:
        server_->broadcast(Topic::kRun, "log", {{"message", "abort: nothing to abort"}});
        return daemon::okReply(r.id, {{"state", state_}});
      default:
        return daemon::okReply(r.id, {{"state", state_}});
    }
  }

  void broadcastRun() {
    ControlServer& s = *server_;
    s.broadcast(daemon::RunStateEvent{{12, 0, "run00"}, "running", std::nullopt});
    for (int i = 0; i < 3; ++i) {
      step_ = i;
      const daemon::StepRef at{12, i, "run0" + std::to_string(i)};
      s.broadcast(daemon::StepStartedEvent{at});
      s.broadcast(
          daemon::ProgressEvent{12, "running", (i + 0.5) / 3, 100.0 * (3 - i), i, at.label});
      s.broadcast(daemon::StepFinishedEvent{at});
    }
    s.broadcast(daemon::AlarmEvent{{12, 2, "run02"}, "chamber 0.4 degC over setpoint"});
    s.broadcast(Topic::kStatus, "estimate",
                {{"parameter", "gyro.bias.x"}, {"value", 1.5e-5}, {"sigma", 2e-7}});
    state_ = "finished";
    s.broadcast(daemon::RunStateEvent{{12, 2, "run02"}, "finished", exit_});
  }

  std::string exit_;
  std::string state_ = "idle";
  int step_ = 0;
  bool played_ = false;
  std::vector<json> requests_;
  EventLoop loop_;
  std::unique_ptr<ControlServer> server_;
  Status start_;
  std::thread thread_;
};

// A listener that accepts one connection, waits for one request line, writes `answer` and
// then hangs up (or keeps the connection open until the test ends, when hang_up is false).
class RawServer {
 public:
  RawServer(const std::string& path, std::string answer, bool hang_up = true) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    EXPECT_EQ(::listen(fd_, 4), 0);
    EXPECT_EQ(::pipe(stop_), 0);
    thread_ = std::thread([this, answer = std::move(answer), hang_up] {
      pollfd p[2] = {{fd_, POLLIN, 0}, {stop_[0], POLLIN, 0}};
      if (::poll(p, 2, 10000) <= 0 || (p[1].revents & POLLIN) != 0) return;
      const int c = ::accept(fd_, nullptr, nullptr);
      if (c < 0) return;
      std::string in;
      char buf[4096];
      while (in.find('\n') == std::string::npos) {
        pollfd q[2] = {{c, POLLIN, 0}, {stop_[0], POLLIN, 0}};
        if (::poll(q, 2, 10000) <= 0 || (q[1].revents & POLLIN) != 0) break;
        const ssize_t n = ::recv(c, buf, sizeof buf, 0);
        if (n <= 0) break;
        in.append(buf, static_cast<std::size_t>(n));
      }
      ::send(c, answer.data(), answer.size(), MSG_NOSIGNAL);
      if (!hang_up) {
        pollfd q{stop_[0], POLLIN, 0};
        ::poll(&q, 1, 20000);
      }
      ::close(c);
    });
  }
  ~RawServer() {
    const char x = 'x';
    EXPECT_EQ(::write(stop_[1], &x, 1), 1);
    thread_.join();
    ::close(fd_);
    ::close(stop_[0]);
    ::close(stop_[1]);
  }

 private:
  int fd_ = -1;
  int stop_[2] = {-1, -1};
  std::thread thread_;
};

class ControlClientTest : public ::testing::Test {
 protected:
  ScratchDir dir_;
  std::string path_ = dir_.file("control.sock");
};

TEST_F(ControlClientTest, MissingSocketNamesThePath) {
  ControlClient c;
  try {
    c.connect(path_);
    FAIL() << "connected to a missing socket";
  } catch (const ControlError& e) {
    EXPECT_EQ(e.kind(), ControlError::Kind::kConnect);
    EXPECT_EQ(std::string(e.what()),
              "is imubenchd running? socket " + path_ + ": No such file or directory");
  }
  EXPECT_FALSE(c.isConnected());
}

TEST_F(ControlClientTest, RoundTripsWithAssignedIds) {
  FakeDaemon d(path_);
  ASSERT_TRUE(d.ok());
  ControlClient c;
  c.connect(path_);
  json reply = c.request({{"cmd", "ping"}});
  EXPECT_EQ(reply, json({{"id", 1}, {"ok", true}, {"result", {{"pong", true}}}}));
  reply = c.request({{"cmd", "status"}});
  EXPECT_EQ(reply["id"], 2);
  EXPECT_EQ(reply["result"]["state"], "idle");
  // An id given by the caller is kept.
  EXPECT_EQ(c.request({{"id", "mine"}, {"cmd", "ping"}})["id"], "mine");
  // ok=false is a reply from request(), a RemoteError from call().
  reply = c.request({{"cmd", "pause"}});
  EXPECT_FALSE(reply["ok"].get<bool>());
  EXPECT_EQ(reply["error"]["code"], "bad_state");
  try {
    c.call({{"cmd", "results"}, {"run", 99}});
    FAIL() << "no RemoteError";
  } catch (const RemoteError& e) {
    EXPECT_EQ(e.code(), "not_found");
    EXPECT_EQ(std::string(e.what()), "error (not_found): no run 99");
  }
  // A request the daemon refuses as malformed is an answer, not a hang.
  reply = c.request({{"cmd", "fly"}});
  EXPECT_EQ(reply["error"]["code"], "unknown_command");
}

TEST_F(ControlClientTest, EventsBetweenRepliesAreQueued) {
  FakeDaemon d(path_);
  ASSERT_TRUE(d.ok());
  ControlClient c;
  c.connect(path_);
  EXPECT_EQ(c.call({{"cmd", "subscribe"}, {"topics", {"run", "status"}}})["topics"],
            json({"run", "status"}));
  EXPECT_FALSE(c.nextEvent(0).has_value());  // nothing yet, no wait
  EXPECT_EQ(c.call({{"cmd", "start"}, {"plan", {{"path", "/p.toml"}}}})["run"], 12);
  EXPECT_EQ(c.call({{"cmd", "status"}})["state"], "running");
  // The run's 13 events follow the status reply.
  WatchState s;
  std::vector<std::string> notes;
  while (!s.ended()) {
    const auto ev = c.nextEvent(5000);
    ASSERT_TRUE(ev.has_value());
    applyEvent(s, *ev, &notes);
  }
  EXPECT_TRUE(s.completed());
  EXPECT_EQ(s.run, 12);
  EXPECT_EQ(notes, (std::vector<std::string>{"ALARM: chamber 0.4 degC over setpoint",
                                             "estimate gyro.bias.x = 1.5e-05 +/- 2e-07"}));
  EXPECT_EQ(c.queuedEvents(), 0u);
  EXPECT_EQ(formatEndLine(s), "run 12 completed");
  // An event broadcast before a reply (the fake's abort) is read with the reply and queued.
  EXPECT_EQ(c.call({{"cmd", "abort"}})["state"], "finished");
  EXPECT_EQ(c.queuedEvents(), 1u);
  const auto ev = c.nextEvent(0);
  ASSERT_TRUE(ev.has_value());
  EXPECT_EQ(*ev,
            json({{"event", "log"}, {"topic", "run"}, {"message", "abort: nothing to abort"}}));
  EXPECT_FALSE(c.nextEvent(0).has_value());
}

TEST_F(ControlClientTest, GarbageLineIsAnErrorNamingIt) {
  RawServer raw(path_, "{\"id\":1,\"ok\":tru\x01\n");
  ControlClient c;
  c.connect(path_);
  try {
    c.request({{"cmd", "ping"}}, 5000);
    FAIL() << "garbage accepted";
  } catch (const ControlError& e) {
    EXPECT_EQ(e.kind(), ControlError::Kind::kProtocol);
    EXPECT_NE(std::string(e.what()).find(R"(not JSON: "{\"id\":1,\"ok\":tru\x01")"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(ControlClientTest, JsonThatIsNoProtocolLineIsAnError) {
  RawServer raw(path_, "[1,2,3]\n");
  ControlClient c;
  c.connect(path_);
  try {
    c.request({{"cmd", "ping"}}, 5000);
    FAIL() << "an array accepted as a reply";
  } catch (const ControlError& e) {
    EXPECT_EQ(e.kind(), ControlError::Kind::kProtocol);
    EXPECT_NE(std::string(e.what()).find("neither a reply nor an event: \"[1,2,3]\""),
              std::string::npos)
        << e.what();
  }
}

TEST_F(ControlClientTest, ServerClosingIsAnError) {
  RawServer raw(path_, "{\"event\":\"state\",\"topic\":\"run\",\"state\":\"running\"}\n{\"id\":1,");
  ControlClient c;
  c.connect(path_);
  try {
    c.request({{"cmd", "ping"}}, 5000);
    FAIL() << "no error on a closed connection";
  } catch (const ControlError& e) {
    EXPECT_EQ(e.kind(), ControlError::Kind::kClosed);
    EXPECT_NE(std::string(e.what()).find("closed the connection"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("in the middle of a line: \"{\\\"id\\\":1,\""),
              std::string::npos)
        << e.what();
  }
  // The event that came before the hang-up is still delivered, then the close is reported.
  const auto ev = c.nextEvent(0);
  ASSERT_TRUE(ev.has_value());
  EXPECT_EQ((*ev)["state"], "running");
  EXPECT_THROW(c.nextEvent(1000), ControlError);
}

TEST_F(ControlClientTest, SilentServerTimesOut) {
  RawServer raw(path_, "", false);
  ControlClient c;
  c.connect(path_);
  try {
    c.request({{"cmd", "status"}}, 200);
    FAIL() << "no timeout";
  } catch (const ControlError& e) {
    EXPECT_EQ(e.kind(), ControlError::Kind::kTimeout);
    EXPECT_NE(std::string(e.what()).find("no reply from imubenchd to \"status\" within 200 ms"),
              std::string::npos)
        << e.what();
  }
}

// ---- the watch fold and its rendering ----
// A status reply of a running run (the protocol's StatusReply).
json runningStatus(int step, std::int64_t count, const std::string& label,
                   std::optional<double> progress, std::optional<double> eta_s) {
  daemon::StatusReply st;
  st.bench = "b";
  st.state = "running";
  st.table = {"closed", false, false, "connected", std::nullopt, std::nullopt, std::nullopt};
  st.run = 12;
  st.plan = "p";
  st.step = daemon::StatusStep{step, label, "rotate", count};
  st.progress = progress;
  st.eta_s = eta_s;
  return toJson(st);
}

json eventLine(const std::string& line) {
  return json::parse(line);
}

// Issue 27 item 3: the follow-up events (daemon/follow_up.h) as watch prints them.
TEST(WatchState, ShowsTheFollowUpAndItsVerdict) {
  WatchState s;
  std::vector<std::string> notes;
  applyEvent(s, json::parse(R"({"event":"follow_up","topic":"run","run":2,"status":"proposed",
      "summary":"follow-up proposed: plan 'follow_up_of_run_2' (732 s) for base_tilt + nonorthogonality"})"),
             &notes);
  applyEvent(s, json::parse(R"({"event":"follow_up","topic":"run","run":3,"status":"refused",
      "summary":"follow-up refused: mounting: no plan"})"),
             &notes);
  applyEvent(s, json::parse(R"({"event":"follow_up_verdict","topic":"run","run":4,"origin_run":2,
      "ok":true,"summary":"base_tilt + nonorthogonality: resolved"})"),
             &notes);
  applyEvent(s, json::parse(R"({"event":"follow_up_verdict","topic":"run","run":5,"origin_run":2,
      "ok":false,"summary":"joint explain: refused"})"),
             &notes);
  const std::vector<std::string> want = {
      "run 2: follow-up proposed: plan 'follow_up_of_run_2' (732 s) for base_tilt + "
      "nonorthogonality (imubench results 2; imubench queue accept 2)",
      "run 3: follow-up refused: mounting: no plan",
      "run 4 (follow-up of run 2): base_tilt + nonorthogonality: resolved",
      "run 5 (follow-up of run 2): joint analysis failed: joint explain: refused"};
  EXPECT_EQ(notes, want);
}

TEST(WatchState, FoldsStatusAndEvents) {
  WatchState s;
  applyStatus(s, runningStatus(3, 45, "run01_x_p1", 0.31, 812.5));
  EXPECT_EQ(formatProgressLine(s, 0),
            "[######..............]  31%  ETA 13:33  step 3/45 run01_x_p1  running");
  EXPECT_EQ(formatProgressLine(s, 30).size(), 30u);
  std::vector<std::string> notes;
  const daemon::StepRef at{12, 3, "run01_x_p1"};
  applyEvent(s, eventLine(serializeEvent(daemon::RunStateEvent{at, "paused", std::nullopt})),
             &notes);
  EXPECT_EQ(s.state, "paused");
  applyEvent(s, eventLine(serializeEvent(daemon::StepStartedEvent{{12, 4, "run01_x_p2"}})), &notes);
  EXPECT_EQ(s.step, 4);
  applyEvent(s, json::parse(R"({"event":"what","topic":"run"})"), &notes);  // ignored
  // An alarm that does not read is still shown, saying what is wrong with it.
  applyEvent(s, json::parse(R"({"event":"alarm","topic":"run"})"), &notes);
  EXPECT_EQ(notes, std::vector<std::string>{"ALARM: (unreadable: alarm.run: missing)"});
  applyEvent(s, eventLine(serializeEvent(daemon::RunStateEvent{at, "faulted", std::nullopt})),
             &notes);
  EXPECT_TRUE(s.ended());
  EXPECT_FALSE(s.completed());
  // Once ended, the state sticks (a later status or event cannot revive the run).
  applyStatus(s, runningStatus(3, 45, "run01_x_p1", 0.31, 812.5));
  EXPECT_EQ(s.state, "faulted");
  EXPECT_EQ(formatEndLine(s), "run 12 faulted");
}

// Issue 28: the bar never goes back within a run (61 % -> 60 % when a step count figure or a
// re-run step followed a planned-time figure); another run starts afresh.
TEST(WatchState, ProgressNeverGoesBackWithinARun) {
  WatchState s;
  applyStatus(s, runningStatus(26, 45, "run14", 0.61, 300.0));
  ASSERT_TRUE(s.progress.has_value());
  applyEvent(s, eventLine(serializeEvent(daemon::StepFinishedEvent{{12, 26, "run14"}})), nullptr);
  EXPECT_DOUBLE_EQ(*s.progress, 0.61) << "27/45 = 0.60 after 0.61";
  applyEvent(
      s, eventLine(serializeEvent(daemon::ProgressEvent{12, "running", 0.605, 290.0, 27, "run15"})),
      nullptr);
  EXPECT_DOUBLE_EQ(*s.progress, 0.61);
  applyStatus(s, runningStatus(27, 45, "run15", 0.6, 280.0));
  EXPECT_DOUBLE_EQ(*s.progress, 0.61);
  applyEvent(
      s, eventLine(serializeEvent(daemon::ProgressEvent{12, "running", 0.62, 270.0, 27, "run15"})),
      nullptr);
  EXPECT_DOUBLE_EQ(*s.progress, 0.62);
  applyEvent(s,
             eventLine(serializeEvent(daemon::ProgressEvent{13, "running", 0.05, 900.0, 1, "h1"})),
             nullptr);
  EXPECT_DOUBLE_EQ(*s.progress, 0.05) << "a new run starts afresh";
}

// Replies and events that are not the protocol's leave the fold as it was (no guessing).
TEST(WatchState, IgnoresWhatIsNotTheProtocols) {
  WatchState s;
  applyStatus(s, json::parse(R"({"step":"x","progress":"a lot","eta_s":null})"));
  EXPECT_EQ(formatProgressLine(s, 0), "[....................]  --%  ?");
  applyStatus(s, json::parse(R"({"step":5,"count":10,"state":"running"})"));  // old guesses
  EXPECT_EQ(formatProgressLine(s, 0), "[....................]  --%  ?");
  applyStatus(s, runningStatus(5, 10, "", std::nullopt, std::nullopt));
  EXPECT_EQ(formatProgressLine(s, 0), "[##########..........]  50%  step 5/10  running");
  applyEvent(s, json::parse(R"({"event":"state","state":"finished","exit":"aborted"})"), nullptr);
  EXPECT_FALSE(s.ended()) << "no run, step or label: not a state event";
  applyEvent(s, eventLine(serializeEvent(daemon::RunFinishedEvent{12, "aborted", "aborted"})),
             nullptr);
  EXPECT_TRUE(s.ended());
  EXPECT_FALSE(s.completed());
  EXPECT_EQ(formatEndLine(s), "run 12 aborted");
  EXPECT_EQ(formatDuration(3723), "1:02:03");
  EXPECT_EQ(formatDuration(-5), "0:00");
}

// ---- the CLI commands, in process, against the fake daemon ----
struct CliResult {
  int code = 0;
  std::string out;
};

CliResult runCli(const std::string& args) {
  CLI::App app{"imubench"};
  app.require_subcommand(1);
  addControlCommands(app);
  std::ostringstream out;
  std::streambuf* old = std::cout.rdbuf(out.rdbuf());
  CliResult r;
  try {
    app.parse(args, false);
  } catch (const CommandFailed& e) {
    out << "imubench: " << e.what() << "\n";
    r.code = e.exitCode();
  } catch (const CLI::ParseError& e) {
    out << "parse error: " << e.what() << "\n";
    r.code = 2;
  }
  std::cout.rdbuf(old);
  r.out = out.str();
  return r;
}

TEST_F(ControlClientTest, CliStartWatchCompletes) {
  FakeDaemon d(path_);
  ASSERT_TRUE(d.ok());
  const std::string plan = std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/two_axis_12run.toml";
  const CliResult r = runCli("start " + plan + " --label T=+20C --watch --socket " + path_);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("started run 12 (plan two_axis_12run) label \"T=+20C\""), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("ALARM: chamber 0.4 degC over setpoint\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("step 2/3 run02"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[####################] 100%"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("run 12 completed\n"), std::string::npos) << r.out;
  const auto reqs = d.requests();
  ASSERT_GE(reqs.size(), 1u);
  EXPECT_EQ(reqs[0]["cmd"], "start");
  // Issue 17: the CLI reads the plan with the operator's rights and sends its text, named by
  // its absolute path (it used to send the path for the daemon to read).
  EXPECT_EQ(reqs[0]["name"], plan);  // absolute
  std::string text;
  ASSERT_TRUE(io::readWholeFile(plan, &text).ok);
  EXPECT_EQ(reqs[0]["toml"], text);
  EXPECT_EQ(reqs[0]["label"], "T=+20C");
}

TEST_F(ControlClientTest, CliWatchExitsNonZeroWhenAborted) {
  FakeDaemon d(path_, "aborted");
  ASSERT_TRUE(d.ok());
  const CliResult idle = runCli("status --socket " + path_);
  EXPECT_EQ(idle.code, 0);
  EXPECT_EQ(idle.out,
            "state: idle\nbench fake: table connected, interlock closed\n"
            "imu: lost samples 0, bad frames 0, restarts 0\n");
  ControlClient starter;
  starter.connect(path_);
  starter.call({{"cmd", "start"}, {"plan", {{"path", "/p.toml"}}}});
  // watch: subscribe, status (running; the fake plays the run after it), events to the end.
  CliResult r = runCli("watch --socket " + path_);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("[....................]   0%  ETA 13:33  step 0/3 place_x_p1  running\n"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("estimate gyro.bias.x = 1.5e-05 +/- 2e-07\n"), std::string::npos) << r.out;
  EXPECT_NE(
      r.out.find("run 12 finished: aborted\nimubench: run 12 finished: aborted (not completed)"),
      std::string::npos)
      << r.out;
}

// (`imubench results` reads the run store now: tools/cli_results.cpp, tested by daemon.e2e.online;
// the daemon's results command through the client: above.)
TEST_F(ControlClientTest, CliErrorsAndJson) {
  FakeDaemon d(path_);
  ASSERT_TRUE(d.ok());
  CliResult r = runCli("pause --socket " + path_);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.out, "imubench: error (bad_state): not running (state idle)\n");
  r = runCli("status --json --socket " + path_);
  EXPECT_EQ(r.code, 0);
  const json j = json::parse(r.out, nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.out;
  EXPECT_EQ(j["result"]["state"], "idle");
  r = runCli("status --socket " + dir_.file("nobody.sock"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("is imubenchd running? socket " + dir_.file("nobody.sock") +
                       ": No such file or directory"),
            std::string::npos)
      << r.out;
  r = runCli("start /no/such/plan.toml --socket " + path_);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("/no/such/plan.toml: no such plan file"), std::string::npos) << r.out;
  r = runCli("start x.toml --dry-run --watch");
  EXPECT_EQ(r.code, 2);
}

}  // namespace
}  // namespace imubench::tools
