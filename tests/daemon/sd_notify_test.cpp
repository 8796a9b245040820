// SystemdNotifier against a stand-in for systemd: an AF_UNIX datagram socket at a temporary
// path named by NOTIFY_SOCKET; the test reads the datagrams the wrapper sent.
#include "daemon/sd_notify.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>

#include "tests/daemon/control_test_util.h"

namespace imubench::daemon {
namespace {

class FakeSystemd {
 public:
  explicit FakeSystemd(const std::string& path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ::setenv("NOTIFY_SOCKET", path.c_str(), 1);
  }
  ~FakeSystemd() {
    ::unsetenv("NOTIFY_SOCKET");
    ::close(fd_);
  }
  FakeSystemd(const FakeSystemd&) = delete;
  FakeSystemd& operator=(const FakeSystemd&) = delete;
  std::optional<std::string> next(int timeout_ms = 2000) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) != 1) return std::nullopt;
    char buf[4096];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n < 0) return std::nullopt;
    return std::string(buf, static_cast<std::size_t>(n));
  }

 private:
  int fd_ = -1;
};

TEST(SystemdNotifier, SendsReadyStatusWatchdogStopping) {
  testing::ScratchDir dir;
  FakeSystemd systemd(dir.file("notify.sock"));
  const SystemdNotifier n;
  bool sent = false;
  ASSERT_TRUE(n.ready(&sent).ok);
  EXPECT_TRUE(sent);
  EXPECT_EQ(systemd.next(), "READY=1");
  ASSERT_TRUE(n.status("running two_axis_12run, step 3/40").ok);
  EXPECT_EQ(systemd.next(), "STATUS=running two_axis_12run, step 3/40");
  ASSERT_TRUE(n.watchdog().ok);
  EXPECT_EQ(systemd.next(), "WATCHDOG=1");
  // A newline cannot smuggle in another assignment.
  ASSERT_TRUE(n.status("idle\nREADY=1").ok);
  EXPECT_EQ(systemd.next(), "STATUS=idle READY=1");
  ASSERT_TRUE(n.stopping().ok);
  EXPECT_EQ(systemd.next(), "STOPPING=1");
}

TEST(SystemdNotifier, OutsideSystemdIsANoOp) {
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  const SystemdNotifier n;
  bool sent = true;
  EXPECT_TRUE(n.ready(&sent).ok);
  EXPECT_FALSE(sent);
  EXPECT_FALSE(n.watchdogInterval().has_value());
  int fd = 0;
  ::unsetenv("LISTEN_FDS");
  EXPECT_TRUE(systemdListenFd(&fd).ok);
  EXPECT_EQ(fd, -1);
}

TEST(SystemdNotifier, WatchdogIntervalFromEnvironment) {
  ::setenv("WATCHDOG_USEC", "30000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  EXPECT_EQ(SystemdNotifier().watchdogInterval(), std::chrono::microseconds(30000000));
  ::setenv("WATCHDOG_PID", "1", 1);  // meant for another process
  EXPECT_FALSE(SystemdNotifier().watchdogInterval().has_value());
  ::unsetenv("WATCHDOG_USEC");
  ::unsetenv("WATCHDOG_PID");
}

}  // namespace
}  // namespace imubench::daemon
