// The control socket on a temporary path, its EventLoop on a thread: request/reply, errors,
// line limits, subscriptions and broadcast, client limits, stale sockets, socket activation,
// and a fuzz/flood test after which the server must still answer a ping promptly. Every wait
// is on a socket's readiness with a timeout, never a fixed sleep.
#include "daemon/control_server.h"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/daemon/control_test_util.h"

namespace imubench::daemon {
namespace {

using nlohmann::json;
using testing::Conn;
using testing::ScratchDir;
using testing::ServerThread;

// The daemon stand-in: status answers with the client id, start is busy, results not_found.
Reply testHandler(const Request& r, ClientId client) {
  switch (r.command) {
    case Command::kStart:
      return errorReply(r.id, ErrorCode::kBusy, "a run is going");
    case Command::kResults:
      return errorReply(r.id, ErrorCode::kNotFound, "no such run");
    default:
      return okReply(r.id, {{"cmd", commandName(r.command)}, {"client", client}});
  }
}

ControlServerOptions optionsAt(const std::string& path) {
  ControlServerOptions o;
  o.socket_path = path;
  return o;
}

// With the request line and per-client output queue limits of a test about them.
ControlServerOptions optionsAt(const std::string& path, std::size_t max_line_bytes,
                               std::size_t max_output_bytes) {
  ControlServerOptions o = optionsAt(path);
  o.max_line_bytes = max_line_bytes;
  o.max_output_bytes = max_output_bytes;
  return o;
}

json readJson(Conn& c, int timeout_ms = 5000) {
  const auto line = c.readLine(timeout_ms);
  if (!line) return json();
  return json::parse(*line, nullptr, false);
}

// A ping answered within 2 s: the loop is alive and not stalled.
void expectPromptPong(const std::string& path, int id) {
  Conn c(path);
  ASSERT_TRUE(c.connected());
  const auto t0 = testing::Clock::now();
  ASSERT_TRUE(c.send("{\"id\":" + std::to_string(id) + ",\"cmd\":\"ping\"}\n"));
  const json j = readJson(c, 2000);
  EXPECT_EQ(j, json({{"id", id}, {"ok", true}, {"result", {{"pong", true}}}}));
  EXPECT_LT(testing::Clock::now() - t0, std::chrono::seconds(2));
}

class ControlServerTest : public ::testing::Test {
 protected:
  ScratchDir dir_;
  std::string path_ = dir_.file("control.sock");
};

TEST_F(ControlServerTest, RequestReplyAndHandlerErrors) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok) << s.startStatus().message;
  struct stat st {};
  ASSERT_EQ(::lstat(path_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  Conn c(path_);
  ASSERT_TRUE(c.connected());
  ASSERT_TRUE(
      c.send("{\"id\":\"s\",\"cmd\":\"status\"}\n{\"id\":2,\"cmd\":\"start\",\"plan\":"
             "{\"path\":\"/p.toml\"}}\r\n\n   \n{\"id\":3,\"cmd\":\"results\",\"run\":9}\n"));
  json j = readJson(c);
  EXPECT_EQ(j["id"], "s");
  EXPECT_EQ(j["result"]["cmd"], "status");
  j = readJson(c);  // CRLF accepted, blank lines ignored
  EXPECT_EQ(
      j, json::parse(R"({"id":2,"ok":false,"error":{"code":"busy","message":"a run is going"}})"));
  j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "not_found");
  EXPECT_EQ(j["id"], 3);
}

TEST_F(ControlServerTest, ProtocolErrorsKeepTheConnection) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn c(path_);
  ASSERT_TRUE(
      c.send("{\"id\":1,\"cmd\":\"ping\"\n{\"id\":2,\"cmd\":\"fly\"}\n"
             "{\"id\":3,\"cmd\":\"pause\",\"x\":1}\n{\"id\":4,\"cmd\":\"ping\"}\n"));
  json j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "bad_json");
  EXPECT_TRUE(j["id"].is_null());  // unreadable line: no id
  EXPECT_EQ(j["error"]["message"].get<std::string>().rfind("byte ", 0), 0u);
  j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "unknown_command");
  EXPECT_EQ(j["id"], 2);
  j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "bad_argument");
  EXPECT_EQ(j["id"], 3);
  EXPECT_EQ(readJson(c)["result"]["pong"], true);
  const ControlServerStats st = s.stats();
  EXPECT_EQ(st.requests, 4u);
  EXPECT_EQ(st.errors, 3u);
}

TEST_F(ControlServerTest, OversizedLineIsRefusedAndTheRestDiscarded) {
  ServerThread s(optionsAt(path_, 1024, 64 * 1024), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn c(path_);
  // 1 MB without a newline, then its end and a ping: one too_large, then the pong.
  const std::string huge(1 << 20, 'a');
  ASSERT_TRUE(c.send(huge));
  ASSERT_TRUE(c.send("{\"tail\":1}\n{\"id\":5,\"cmd\":\"ping\"}\n"));
  json j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "too_large");
  EXPECT_NE(j["error"]["message"].get<std::string>().find("1024"), std::string::npos);
  EXPECT_EQ(readJson(c)["id"], 5);
  // Exactly at the limit is fine; one byte more is not (complete lines, one read).
  std::string at_limit = "{\"id\":6,\"cmd\":\"ping\"}";
  at_limit += std::string(1024 - at_limit.size(), ' ');
  ASSERT_TRUE(c.send(at_limit + "\n" + at_limit + " \n{\"id\":7,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(c)["id"], 6);
  EXPECT_EQ(readJson(c)["error"]["code"], "too_large");
  EXPECT_EQ(readJson(c)["id"], 7);
}

TEST_F(ControlServerTest, SubscribersGetBroadcastsOthersDoNot) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn a(path_), b(path_);
  ASSERT_TRUE(a.send("{\"id\":1,\"cmd\":\"subscribe\",\"topics\":[\"run\",\"log\"]}\n"));
  EXPECT_EQ(readJson(a)["result"]["topics"], json({"run", "log"}));
  ASSERT_TRUE(b.send("{\"id\":1,\"cmd\":\"subscribe\",\"topics\":[\"status\"]}\n"));
  EXPECT_EQ(readJson(b)["result"]["topics"], json({"status"}));
  s.onLoop([&s] {
    s.server().broadcast(Topic::kRun, "step_started", {{"step", 4}, {"label", "rot +z"}});
    return 0;
  });
  EXPECT_EQ(readJson(a), json::parse(R"({"event":"step_started","topic":"run","step":4,
                                          "label":"rot +z"})"));
  // b is not on "run": its next line is the reply to its ping, not the event.
  ASSERT_TRUE(b.send("{\"id\":2,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(b)["id"], 2);
  // Unsubscribed from everything, a gets nothing more either.
  ASSERT_TRUE(a.send("{\"id\":3,\"cmd\":\"unsubscribe\"}\n"));
  EXPECT_EQ(readJson(a)["result"]["topics"], json::array());
  s.onLoop([&s] {
    s.server().broadcast(Topic::kRun, "step_finished");
    return 0;
  });
  ASSERT_TRUE(a.send("{\"id\":4,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(a)["id"], 4);
}

TEST_F(ControlServerTest, HalfClosedClientStillGetsItsReply) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn c(path_);
  ASSERT_TRUE(c.send("{\"id\":1,\"cmd\":\"ping\"}\n{\"id\":2,\"cmd\":\"status\"}"));  // no \n
  c.shutdownWrite();
  EXPECT_EQ(readJson(c)["id"], 1);
  EXPECT_EQ(readJson(c)["id"], 2);
  EXPECT_TRUE(c.waitClosed());
}

// Without reserved slots (issue 17 added them; see ReservedSlotTakesStopStatusAndPing), a
// client past max_clients is refused.
TEST_F(ControlServerTest, TooManyClientsAreToldBusy) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 2;
  o.reserved_clients = 0;
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn a(path_), b(path_);
  ASSERT_TRUE(a.send("{\"cmd\":\"ping\"}\n"));
  ASSERT_TRUE(b.send("{\"cmd\":\"ping\"}\n"));
  ASSERT_TRUE(readJson(a)["ok"]);
  ASSERT_TRUE(readJson(b)["ok"]);
  Conn c(path_);
  EXPECT_EQ(readJson(c)["error"]["code"], "busy");
  EXPECT_TRUE(c.waitClosed());
  EXPECT_EQ(s.stats().refused_busy, 1u);
}

// Issue 17: with every regular slot held by idle connections, a further connection still gets
// the emergency stop through (a reserved slot), but nothing else; past the reserved slots too,
// connections are refused.
TEST_F(ControlServerTest, ReservedSlotTakesStopStatusAndPing) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 2;
  o.reserved_clients = 1;
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn a(path_), b(path_);
  for (Conn* c : {&a, &b}) {
    ASSERT_TRUE(c->send("{\"cmd\":\"ping\"}\n"));
    ASSERT_TRUE(readJson(*c)["ok"]);
  }
  Conn r(path_);
  ASSERT_TRUE(
      r.send("{\"id\":1,\"cmd\":\"stop\"}\n{\"id\":2,\"cmd\":\"status\"}\n"
             "{\"id\":3,\"cmd\":\"ping\"}\n{\"id\":4,\"cmd\":\"pause\"}\n"
             "{\"id\":5,\"cmd\":\"subscribe\",\"topics\":[\"run\"]}\n"));
  EXPECT_EQ(readJson(r),
            json({{"id", 1}, {"ok", true}, {"result", {{"cmd", "stop"}, {"client", 3}}}}));
  EXPECT_EQ(readJson(r)["result"]["cmd"], "status");
  EXPECT_EQ(readJson(r)["result"]["pong"], true);
  for (int id : {4, 5}) {
    const json j = readJson(r);
    EXPECT_EQ(j["id"], id);
    EXPECT_EQ(j["error"]["code"], "busy");
    EXPECT_NE(j["error"]["message"].get<std::string>().find("takes only stop, status and ping"),
              std::string::npos);
  }
  Conn refused(path_);
  EXPECT_EQ(readJson(refused)["error"]["code"], "busy");
  EXPECT_TRUE(refused.waitClosed());
  const ControlServerStats st = s.stats();
  EXPECT_EQ(st.reserved_accepted, 1u);
  EXPECT_EQ(st.refused_busy, 1u);
}

// Issue 28: reserved slots go only to peers the policy calls privileged (root and the command
// group in imubenchd); others are told busy and where the stop socket is.
TEST_F(ControlServerTest, ReservedSlotsOnlyForPrivilegedPeers) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 1;
  o.reserved_clients = 1;
  o.stop_socket_path = path_ + ".stop";
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  bool privileged = false;
  s.onLoop([&] {
    s.server().setPeerPolicy([&privileged](const PeerCredentials& p) {
      EXPECT_TRUE(p.known);
      return ControlServer::PeerClass{privileged, false};
    });
    return 0;
  });
  Conn a(path_);
  ASSERT_TRUE(a.send("{\"cmd\":\"ping\"}\n"));
  ASSERT_TRUE(readJson(a)["ok"]);
  Conn stranger(path_);
  const json busy = readJson(stranger);
  EXPECT_EQ(busy["error"]["code"], "busy");
  EXPECT_NE(busy["error"]["message"].get<std::string>().find(o.stop_socket_path), std::string::npos)
      << busy;
  EXPECT_TRUE(stranger.waitClosed());
  s.onLoop([&] { return privileged = true; });
  Conn root(path_);
  ASSERT_TRUE(root.send("{\"id\":1,\"cmd\":\"stop\"}\n"));
  EXPECT_EQ(readJson(root)["result"]["cmd"], "stop");
  EXPECT_EQ(s.stats().reserved_accepted, 1u);
}

// Issue 28: one uid holds at most max_connections_per_uid connections; a new one closes that
// uid's least recently active connection (here: the oldest idle ones), not a busy refusal.
TEST_F(ControlServerTest, ConnectionsPerUidAreBounded) {
  ControlServerOptions o = optionsAt(path_);
  o.max_connections_per_uid = 3;
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  s.onLoop([&] {
    s.server().setPeerPolicy([](const PeerCredentials&) { return ControlServer::PeerClass{}; });
    return 0;
  });
  std::vector<std::unique_ptr<Conn>> conns;
  for (int i = 0; i < 3; ++i) {
    conns.push_back(std::make_unique<Conn>(path_));
    ASSERT_TRUE(conns.back()->send("{\"cmd\":\"ping\"}\n"));
    ASSERT_TRUE(readJson(*conns.back())["ok"]);
  }
  // The first is active again: the second is now the least recently active.
  ASSERT_TRUE(conns[0]->send("{\"cmd\":\"ping\"}\n"));
  ASSERT_TRUE(readJson(*conns[0])["ok"]);
  for (int i = 0; i < 2; ++i) {
    conns.push_back(std::make_unique<Conn>(path_));
    ASSERT_TRUE(conns.back()->send("{\"cmd\":\"ping\"}\n"));
    ASSERT_TRUE(readJson(*conns.back())["ok"]) << "the new connection is served";
  }
  EXPECT_TRUE(conns[1]->waitClosed());
  EXPECT_TRUE(conns[2]->waitClosed());
  for (const std::size_t i : {0u, 3u, 4u}) {
    ASSERT_TRUE(conns[i]->send("{\"cmd\":\"ping\"}\n"));
    EXPECT_TRUE(readJson(*conns[i])["ok"]) << i;
  }
  EXPECT_EQ(s.stats().uid_limit_closes, 2u);
  EXPECT_EQ(s.stats().refused_busy, 0u);
}

// Issue 28: the stop socket takes a stop whatever holds the control socket, only a stop, and
// never fills (a new connection closes the oldest); its file goes with the server.
TEST_F(ControlServerTest, StopSocketTakesOnlyStopAndNeverFills) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 2;
  o.reserved_clients = 0;
  o.max_stop_clients = 3;
  o.stop_socket_path = path_ + ".stop";
  {
    ServerThread s(o, testHandler);
    ASSERT_TRUE(s.startStatus().ok);
    struct stat st {};
    ASSERT_EQ(::lstat(o.stop_socket_path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0660u);
    Conn a(path_), b(path_);
    for (Conn* c : {&a, &b}) {
      ASSERT_TRUE(c->send("{\"cmd\":\"ping\"}\n"));
      ASSERT_TRUE(readJson(*c)["ok"]);
    }
    Conn full(path_);
    EXPECT_EQ(readJson(full)["error"]["code"], "busy");
    std::vector<std::unique_ptr<Conn>> held;
    for (int i = 0; i < 3; ++i) held.push_back(std::make_unique<Conn>(o.stop_socket_path));
    Conn stopper(o.stop_socket_path);
    ASSERT_TRUE(stopper.send("{\"id\":7,\"cmd\":\"stop\"}\n{\"id\":8,\"cmd\":\"status\"}\n"));
    EXPECT_EQ(readJson(stopper),
              json({{"id", 7}, {"ok", true}, {"result", {{"cmd", "stop"}, {"client", 6}}}}));
    const json refused = readJson(stopper);
    EXPECT_EQ(refused["id"], 8);
    EXPECT_EQ(refused["error"]["code"], "bad_argument");
    EXPECT_NE(refused["error"]["message"].get<std::string>().find("takes only"), std::string::npos);
    EXPECT_TRUE(held[0]->waitClosed()) << "the oldest stop connection made room";
    EXPECT_EQ(s.stats().stop_accepted, 4u);
  }
  struct stat st {};
  EXPECT_NE(::lstat(o.stop_socket_path.c_str(), &st), 0) << "stop socket left behind";
}

// Issue 15: the access policy sees every request (the server's own ping and subscribe too) with
// the peer's SO_PEERCRED credentials; a refusal is "forbidden" and the connection stays.
TEST_F(ControlServerTest, AccessPolicyRefusesWithForbidden) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  std::vector<std::pair<Command, PeerCredentials>> seen;
  s.onLoop([&] {
    s.server().setAccessPolicy(
        [&seen](Command c, const PeerCredentials& p) -> std::optional<std::string> {
          seen.emplace_back(c, p);
          if (c == Command::kStop || c == Command::kStatus) return std::nullopt;
          return std::string(commandName(c)) + ": forbidden for uid " + std::to_string(p.uid);
        });
    return 0;
  });
  Conn c(path_);
  ASSERT_TRUE(
      c.send("{\"id\":1,\"cmd\":\"start\",\"plan\":{\"path\":\"/p.toml\"}}\n"
             "{\"id\":2,\"cmd\":\"subscribe\",\"topics\":[\"run\"]}\n{\"id\":3,\"cmd\":\"ping\"}\n"
             "{\"id\":4,\"cmd\":\"status\"}\n{\"id\":5,\"cmd\":\"stop\"}\n"));
  for (int id : {1, 2, 3}) {
    const json j = readJson(c);
    EXPECT_EQ(j["id"], id);
    EXPECT_EQ(j["error"]["code"], "forbidden");
    EXPECT_NE(j["error"]["message"].get<std::string>().find("forbidden for uid " +
                                                            std::to_string(::getuid())),
              std::string::npos)
        << j;
  }
  EXPECT_EQ(readJson(c)["result"]["cmd"], "status");
  EXPECT_EQ(readJson(c)["result"]["cmd"], "stop");
  const auto seen_now = s.onLoop([&] { return seen; });
  ASSERT_EQ(seen_now.size(), 5u);
  for (const auto& [cmd, p] : seen_now) {
    EXPECT_TRUE(p.known);
    EXPECT_EQ(p.uid, ::getuid());
    EXPECT_EQ(p.gid, ::getgid());
    EXPECT_EQ(p.pid, ::getpid());
  }
  EXPECT_EQ(s.stats().forbidden, 3u);
}

// Issue 17: a connection that sends nothing for idle_timeout_s is closed and its slot is free
// again; a subscriber that reads its events stays however long it waits; one that does not
// read what it was sent is idle too.
TEST_F(ControlServerTest, IdleClientsAreClosedReadingSubscribersStay) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 3;
  o.reserved_clients = 0;
  o.idle_timeout_s = 0.3;
  o.max_output_bytes = 16 * 1024 * 1024;  // the deaf subscriber is dropped as idle, not overflow
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn idle(path_), watcher(path_), deaf(path_);
  for (Conn* c : {&watcher, &deaf}) {
    ASSERT_TRUE(c->send("{\"cmd\":\"subscribe\",\"topics\":[\"status\"]}\n"));
    ASSERT_TRUE(readJson(*c)["ok"]);
  }
  const auto t0 = testing::Clock::now();
  EXPECT_TRUE(idle.waitClosed(3000));
  EXPECT_GE(testing::Clock::now() - t0, std::chrono::milliseconds(200));
  // More events than the deaf subscriber's socket holds: the rest waits in its queue, unread.
  const std::string pad(8000, 'x');
  for (int n = 0; n < 100; ++n) {
    s.onLoop([&s, &pad, n] {
      s.server().broadcast(Topic::kStatus, "status", {{"n", n}, {"pad", pad}});
      return 0;
    });
    ASSERT_EQ(readJson(watcher)["n"], n);
  }
  // Waits for the hang-up without reading (reading would make the deaf client a reader).
  pollfd hup{deaf.fd(), 0, 0};
  EXPECT_EQ(::poll(&hup, 1, 5000), 1);
  EXPECT_NE(hup.revents & POLLHUP, 0);
  EXPECT_EQ(s.stats().idle_disconnects, 2u);
  EXPECT_EQ(s.stats().overflow_disconnects, 0u);
  // Well past the timeout, the reading watcher is still served; the freed slots take clients.
  ASSERT_TRUE(watcher.send("{\"id\":9,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(watcher)["id"], 9);
  Conn again(path_);
  ASSERT_TRUE(again.send("{\"cmd\":\"status\"}\n"));
  EXPECT_TRUE(readJson(again)["ok"]);
}

// A handler may answer later (work off the loop thread): nullopt now, sendReply when done.
TEST_F(ControlServerTest, DeferredReplyArrivesThroughSendReply) {
  std::optional<std::pair<ClientId, Reply>> pending;  // touched on the loop thread only
  ServerThread s(optionsAt(path_),
                 [&pending](const Request& r, ClientId client) -> std::optional<Reply> {
                   if (r.command != Command::kValidatePlan) return testHandler(r, client);
                   pending.emplace(client, okReply(r.id, {{"deferred", true}}));
                   return std::nullopt;
                 });
  ASSERT_TRUE(s.startStatus().ok);
  Conn c(path_);
  ASSERT_TRUE(
      c.send("{\"id\":1,\"cmd\":\"validate_plan\",\"plan\":{\"toml\":\"x\"}}\n"
             "{\"id\":2,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(c)["id"], 2);  // nothing for request 1 yet; the ping is answered
  EXPECT_TRUE(s.onLoop(
      [&s, &pending] { return pending && s.server().sendReply(pending->first, pending->second); }));
  EXPECT_EQ(readJson(c), json({{"id", 1}, {"ok", true}, {"result", {{"deferred", true}}}}));
  EXPECT_FALSE(s.onLoop([&s] { return s.server().sendReply(999, okReply(nullptr)); }));
}

// A client that sends requests and never reads its replies is dropped when its queue passes
// max_output_bytes; meanwhile another client is answered promptly.
TEST_F(ControlServerTest, ClientThatNeverReadsIsDisconnected) {
  ServerThread s(optionsAt(path_, 1024, 16 * 1024), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn slow(path_);
  int rcvbuf = 4096;
  ::setsockopt(slow.fd(), SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  std::string burst;
  for (int i = 0; i < 200; ++i) burst += "{\"id\":" + std::to_string(i) + ",\"cmd\":\"status\"}\n";
  // Keep writing (never reading) until the server hangs up; bounded by a deadline.
  const auto deadline = testing::Clock::now() + std::chrono::seconds(20);
  while (s.stats().overflow_disconnects == 0 && testing::Clock::now() < deadline) {
    pollfd p{slow.fd(), POLLOUT, 0};
    if (::poll(&p, 1, 200) == 1 && (p.revents & POLLOUT) != 0) slow.sendNoRead(burst);
    if (p.revents & (POLLHUP | POLLERR)) break;
    expectPromptPong(path_, 77);  // others are served while the slow client piles up
  }
  EXPECT_GE(s.stats().overflow_disconnects, 1u);
  EXPECT_TRUE(slow.waitClosed());
  expectPromptPong(path_, 78);
}

TEST_F(ControlServerTest, SubscriberThatNeverReadsIsDisconnectedOnBroadcast) {
  ServerThread s(optionsAt(path_, 1024, 8 * 1024), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn stuck(path_), good(path_);
  for (Conn* c : {&stuck, &good}) {
    ASSERT_TRUE(c->send("{\"cmd\":\"subscribe\",\"topics\":[\"status\"]}\n"));
    ASSERT_TRUE(readJson(*c)["ok"]);
  }
  const std::string pad(900, 'x');
  int received = 0;
  for (int round = 0; round < 2000 && s.stats().overflow_disconnects == 0; ++round) {
    s.onLoop([&s, &pad, round] {
      s.server().broadcast(Topic::kStatus, "status", {{"n", round}, {"pad", pad}});
      return 0;
    });
    ASSERT_EQ(readJson(good)["n"], round);  // the reading subscriber gets each event
    ++received;
  }
  EXPECT_EQ(s.stats().overflow_disconnects, 1u);
  EXPECT_TRUE(stuck.waitClosed());
  EXPECT_GT(received, 0);
  expectPromptPong(path_, 1);
}

TEST_F(ControlServerTest, StaleSocketReplacedLiveOneAndFilesRefused) {
  {  // a socket file nobody listens on (its server died)
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ::close(fd);
  }
  {
    ServerThread live(optionsAt(path_), testHandler);
    ASSERT_TRUE(live.startStatus().ok) << live.startStatus().message;
    ServerThread second(optionsAt(path_), testHandler);
    EXPECT_FALSE(second.startStatus().ok);
    EXPECT_NE(second.startStatus().message.find("another server is listening"), std::string::npos);
    expectPromptPong(path_, 1);  // the second server did not remove the live one's socket
  }
  struct stat st {};
  EXPECT_NE(::lstat(path_.c_str(), &st), 0) << "the server removes its socket file";
  const std::string file = dir_.file("plain");
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fclose(f);
  ServerThread s(optionsAt(file), testHandler);
  EXPECT_NE(s.startStatus().message.find("exists and is not a socket"), std::string::npos);
}

TEST_F(ControlServerTest, InheritedListeningSocket) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ControlServerOptions o;
  o.listen_fd = fd;
  {
    ServerThread notyet(o, testHandler);  // bound but not listening: refused
    EXPECT_NE(notyet.startStatus().message.find("not listening"), std::string::npos);
  }
  ASSERT_EQ(::listen(fd, 8), 0);
  ServerThread s(o, testHandler);  // adopts fd (and closes it at the end)
  ASSERT_TRUE(s.startStatus().ok) << s.startStatus().message;
  expectPromptPong(path_, 3);
}

TEST(ControlServerOptions, Validation) {
  ControlServerOptions o;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("socket_path"), std::string::npos);
  o.socket_path = "/run/imubench/control.sock";
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.socket_path = std::string(120, 'x');
  EXPECT_FALSE(o.IsValid(&why));
  o.socket_path = "/s";
  o.max_clients = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o.max_clients = 1;
  o.idle_timeout_s = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("idle_timeout_s"), std::string::npos);
  o.idle_timeout_s = 0.0;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.max_output_bytes = 100;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_output_bytes"), std::string::npos);
  o.max_output_bytes = 1 << 20;
  o.socket_mode = 04777;
  EXPECT_FALSE(o.IsValid(&why));
}

// Fuzz and flood: random bytes, mutated valid requests, unknown commands, huge lines and 10k
// requests from each of several clients at once. Every reply is a valid protocol line, the
// flood clients get every reply in order, and the server still answers a ping promptly.
std::string randomBytes(std::mt19937& rng, std::size_t n) {
  std::string s(n, '\0');
  for (char& ch : s) ch = static_cast<char>(rng() % 256);
  return s;
}

std::string mutatedRequest(std::mt19937& rng) {
  static const std::string valid[] = {
      R"({"id":1,"cmd":"start","plan":{"toml":"[plan]"},"options":{"label":"x"}})",
      R"({"id":"a","cmd":"subscribe","topics":["run"]})", R"({"cmd":"export","run":3,"dir":"/e"})",
      R"({"id":2,"cmd":"unsubscribe"})", R"({"id":4,"cmd":"results"})"};
  std::string line = valid[rng() % 5];
  for (int m = 0, n = 1 + static_cast<int>(rng() % 3); m < n; ++m) {
    char ch = static_cast<char>(rng() % 256);
    if (ch == '\n') ch = ' ';
    line[rng() % line.size()] = ch;
  }
  return line;
}

bool isProtocolLine(const json& j) {
  if (!j.is_object()) return false;
  if (j.contains("event")) return j["event"].is_string();
  if (!j.contains("ok") || !j["ok"].is_boolean()) return false;
  if (j["ok"]) return j["result"].is_object();
  static const std::vector<std::string> codes = {
      "bad_json",  "unknown_command", "bad_argument", "too_large", "busy",
      "bad_state", "not_found",       "bad_plan",     "internal"};
  const json& e = j["error"];
  return e.is_object() && e["message"].is_string() && !e["message"].get<std::string>().empty() &&
         std::find(codes.begin(), codes.end(), e["code"].get<std::string>()) != codes.end();
}

void floodClient(const std::string& path, int client, int requests, int* answered) {
  Conn c(path);
  if (!c.connected()) return;
  std::string batch;
  int next_reply = 0;
  for (int i = 0; i < requests; ++i) {
    batch += "{\"id\":" + std::to_string(client * 1000000 + i) + ",\"cmd\":\"" +
             (i % 3 == 0 ? "status" : (i % 3 == 1 ? "ping" : "warp")) + "\"}\n";
    if (batch.size() < 4096 && i + 1 < requests) continue;
    if (!c.send(batch)) return;
    batch.clear();
    // Read what has arrived so far: replies come in request order.
    while (next_reply <= i) {
      const auto line = c.readLine(next_reply < i - 200 ? 5000 : 0);
      if (!line) break;
      const json j = json::parse(*line, nullptr, false);
      if (!isProtocolLine(j) || j["id"] != client * 1000000 + next_reply) return;
      ++next_reply;
    }
  }
  while (next_reply < requests) {
    const auto line = c.readLine(10000);
    if (!line) return;
    const json j = json::parse(*line, nullptr, false);
    if (!isProtocolLine(j) || j["id"] != client * 1000000 + next_reply) return;
    ++next_reply;
  }
  *answered = next_reply;
}

// Issue 28 item 1: the line that killed imubenchd (an out-of-range number escaped the parser
// and the event loop) and deep nesting are error replies on the same connection; the loop
// goes on.
TEST_F(ControlServerTest, OutOfRangeNumbersAndDeepNestingAreErrorReplies) {
  ServerThread s(optionsAt(path_), testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  Conn c(path_);
  ASSERT_TRUE(c.send("{\"cmd\":\"ping\",\"id\":1e400}\n"));
  json j = readJson(c);
  EXPECT_EQ(j["error"]["code"], "bad_json") << j;
  EXPECT_NE(j["error"]["message"].get<std::string>().find("1e400"), std::string::npos) << j;
  ASSERT_TRUE(c.send("{\"cmd\":\"results\",\"run\":" + std::string(400, '9') + "}\n" +
                     std::string(50000, '[') + "\n{\"id\":2,\"cmd\":\"ping\"}\n"));
  EXPECT_EQ(readJson(c)["error"]["code"], "bad_json");
  EXPECT_EQ(readJson(c)["error"]["code"], "bad_json");
  EXPECT_EQ(readJson(c)["result"]["pong"], true);
  expectPromptPong(path_, 3);
}

TEST_F(ControlServerTest, FuzzAndFloodLeaveTheServerResponsive) {
  ControlServerOptions o = optionsAt(path_);
  o.max_clients = 32;
  ServerThread s(o, testHandler);
  ASSERT_TRUE(s.startStatus().ok);
  std::mt19937 rng(7);
  int bad_lines = 0;
  {
    Conn fuzz(path_);
    for (int i = 0; i < 3000; ++i) {
      std::string chunk;
      switch (i % 4) {
        case 0:
          chunk = randomBytes(rng, 1 + rng() % 200) + "\n";
          break;
        case 1:
          chunk = mutatedRequest(rng) + "\n";
          break;
        case 2:
          chunk = "{\"id\":" + std::to_string(i) + ",\"cmd\":\"" + randomBytes(rng, 8) + "\"}\n";
          break;
        default:
          chunk = randomBytes(rng, 1 + rng() % 64);  // no newline: joins the next line
      }
      ASSERT_TRUE(fuzz.send(chunk)) << "the server hung up on the fuzz client at " << i;
      while (auto line = fuzz.readLine(0)) {
        const json j = json::parse(*line, nullptr, false);
        EXPECT_TRUE(isProtocolLine(j)) << *line;
        ++bad_lines;
      }
    }
    ASSERT_TRUE(fuzz.send(std::string(1 << 20, '{')));  // 1 MB, no newline
    ASSERT_TRUE(fuzz.send("\n{\"id\":\"end\",\"cmd\":\"ping\"}\n"));
    for (;;) {  // drain to the final pong
      const auto line = fuzz.readLine(5000);
      ASSERT_TRUE(line.has_value());
      const json j = json::parse(*line, nullptr, false);
      ASSERT_TRUE(isProtocolLine(j)) << *line;
      if (j["id"] == "end") break;
    }
  }
  EXPECT_GT(bad_lines, 1000);
  constexpr int kClients = 4;
  constexpr int kRequests = 10000;
  std::vector<int> answered(kClients, 0);
  std::vector<std::thread> threads;
  for (int k = 0; k < kClients; ++k)
    threads.emplace_back(floodClient, path_, k + 1, kRequests, &answered[k]);
  expectPromptPong(path_, 99);  // answered while the flood runs
  for (auto& t : threads) t.join();
  for (int k = 0; k < kClients; ++k) EXPECT_EQ(answered[k], kRequests) << "client " << k + 1;
  expectPromptPong(path_, 100);
  EXPECT_EQ(s.stats().overflow_disconnects, 0u);  // every client read its replies
}

}  // namespace
}  // namespace imubench::daemon
