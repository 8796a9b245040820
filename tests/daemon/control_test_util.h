// Helpers for the control socket tests: a scratch directory (mkdtemp), a client connection
// that waits on readiness with timeouts (never fixed sleeps), and a server running its
// EventLoop on a thread.
#pragma once

#include <gtest/gtest.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "daemon/control_server.h"
#include "daemon/event_loop.h"
#include "tests/daemon/scratch_dir.h"

namespace imubench::daemon::testing {

using Clock = std::chrono::steady_clock;
inline int msLeft(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return left.count() > 0 ? static_cast<int>(left.count()) : 0;
}

// A client connection. send() keeps reading while it writes, so a test client never deadlocks
// against a server whose replies fill the socket (that is what a well-behaved client does).
class Conn {
 public:
  explicit Conn(const std::string& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Conn() {
    if (fd_ >= 0) ::close(fd_);
  }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  bool connected() const { return connected_; }
  int fd() const { return fd_; }
  bool eof() const { return eof_; }

  // Writes all of data (reading replies meanwhile); false on a socket error or timeout.
  bool send(std::string_view data, int timeout_ms = 10000) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!data.empty()) {
      pollfd p{fd_, static_cast<short>(POLLOUT | (eof_ ? 0 : POLLIN)), 0};
      if (::poll(&p, 1, msLeft(deadline)) <= 0) return false;
      if ((p.revents & POLLIN) != 0) drain();
      if ((p.revents & (POLLERR | POLLHUP)) != 0 && (p.revents & POLLOUT) == 0) return false;
      if ((p.revents & POLLOUT) == 0) continue;
      const ssize_t n = ::send(fd_, data.data(), data.size(), MSG_NOSIGNAL);
      if (n < 0 && errno != EAGAIN) return false;
      if (n > 0) data.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
  }
  // Sends without reading (a misbehaving client); returns bytes written before it would block.
  std::size_t sendNoRead(std::string_view data) {
    const ssize_t n = ::send(fd_, data.data(), data.size(), MSG_NOSIGNAL);
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }
  // The next complete line (without newline), waiting up to timeout_ms; nullopt on timeout/EOF.
  std::optional<std::string> readLine(int timeout_ms = 5000) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      const auto nl = in_.find('\n');
      if (nl != std::string::npos) {
        std::string line = in_.substr(0, nl);
        in_.erase(0, nl + 1);
        return line;
      }
      if (eof_) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, msLeft(deadline)) <= 0) return std::nullopt;
      drain();
    }
  }
  // Waits until the server closes the connection (reading and dropping what it sent).
  bool waitClosed(int timeout_ms = 5000) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!eof_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, msLeft(deadline)) <= 0) return false;
      drain();
      in_.clear();
    }
    return true;
  }
  void shutdownWrite() { ::shutdown(fd_, SHUT_WR); }

 private:
  void drain() {
    char buf[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        in_.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) eof_ = true;
      return;
    }
  }
  int fd_ = -1;
  bool connected_ = false;
  bool eof_ = false;
  std::string in_;
};

// A ControlServer whose loop runs on its own thread; onLoop() runs code on that thread.
class ServerThread {
 public:
  ServerThread(ControlServerOptions options, ControlServer::Handler handler) {
    EXPECT_TRUE(loop_.open().ok);
    server_ =
        std::make_unique<ControlServer>(&loop_, std::move(options), std::move(handler), nullptr);
    start_status_ = server_->start();
    if (start_status_.ok) thread_ = std::thread([this] { run_status_ = loop_.run(); });
  }
  ~ServerThread() {
    if (thread_.joinable()) {
      loop_.stop();
      thread_.join();
    }
    EXPECT_TRUE(run_status_.ok) << run_status_.message;
  }
  const Status& startStatus() const { return start_status_; }
  template <typename F>
  auto onLoop(F fn) {
    std::packaged_task<decltype(fn())()> task(std::move(fn));
    auto result = task.get_future();
    loop_.post([&task] { task(); });
    if (result.wait_for(std::chrono::seconds(10)) != std::future_status::ready)
      ADD_FAILURE() << "the loop did not run posted work within 10 s";
    return result.get();
  }
  ControlServerStats stats() {
    return onLoop([this] { return server_->stats(); });
  }
  ControlServer& server() { return *server_; }

 private:
  EventLoop loop_;
  std::unique_ptr<ControlServer> server_;
  Status start_status_;
  Status run_status_;
  std::thread thread_;
};

}  // namespace imubench::daemon::testing
