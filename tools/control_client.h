// A small blocking client for imubenchd's control socket (the NDJSON protocol of
// daemon/control_protocol.h): connect, one request at a time with an id it assigns and matches,
// and the event lines that arrive between replies kept in a queue for nextEvent().
//
// Every wait is a poll() with a timeout. Nothing the socket sends can crash it: a line that is
// not a protocol line (not JSON, not an object, neither a reply nor an event, or longer than
// kMaxLineBytes) is a ControlError naming the line. Not thread-safe: one thread per client.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

namespace imubench::tools {

// Where imubenchd listens (systemd/imubenchd.socket); IMUBENCH_SOCKET overrides it.
inline constexpr const char* kDefaultControlSocket = "/run/imubench/control.sock";
// $IMUBENCH_SOCKET when set and non-empty, else kDefaultControlSocket.
std::string defaultControlSocket();

class ControlError : public std::runtime_error {
 public:
  enum class Kind {
    kConnect,   // could not connect (no daemon, no permission, path too long)
    kTimeout,   // no reply within the timeout
    kClosed,    // the daemon closed the connection
    kProtocol,  // the daemon sent something that is not a protocol line
    kIo,        // a socket error
    kRemote,    // the daemon answered ok=false (call() only): code() and remoteMessage()
  };
  ControlError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// An ok=false reply: what() is "error (code): message".
class RemoteError : public ControlError {
 public:
  RemoteError(std::string code, std::string message);
  const std::string& code() const { return code_; }
  const std::string& remoteMessage() const { return message_; }

 private:
  std::string code_;
  std::string message_;
};

class ControlClient {
 public:
  // Lines longer than this are refused (the daemon's replies and events are far smaller).
  static constexpr std::size_t kMaxLineBytes = 4 * 1024 * 1024;
  static constexpr int kDefaultTimeoutMs = 10000;

  ControlClient() = default;
  ~ControlClient();
  ControlClient(const ControlClient&) = delete;
  ControlClient& operator=(const ControlClient&) = delete;

  // Throws ControlError(kConnect) naming the path and the errno text, e.g.
  // "is imubenchd running? socket /run/imubench/control.sock: No such file or directory".
  void connect(const std::string& path);
  void close();
  bool isConnected() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }

  // Sends request (an object with "cmd"; an integer "id" is assigned unless it has one) and
  // returns the reply object with that id (ok true or false). Events read meanwhile are queued.
  // Replies with another id (late answers to requests that timed out) are dropped. Throws
  // ControlError on timeout, a closed connection, a socket error or a malformed line.
  nlohmann::json request(nlohmann::json request, int timeout_ms = kDefaultTimeoutMs);
  // request(), then the reply's result; an ok=false reply throws RemoteError.
  nlohmann::json call(nlohmann::json request, int timeout_ms = kDefaultTimeoutMs);

  // The next event (queued, or read within timeout_ms; -1 waits forever). nullopt on timeout.
  // Throws ControlError when the connection closes or a malformed line arrives. A reply line
  // read here (to no pending request) is dropped.
  std::optional<nlohmann::json> nextEvent(int timeout_ms);
  std::size_t queuedEvents() const { return events_.size(); }
  // The id the next request gets.
  std::int64_t nextId() const { return next_id_; }

 private:
  enum class LineKind { kReply, kEvent };
  // Reads what the socket has within timeout_ms into in_; false on timeout.
  bool readSome(int timeout_ms);
  void sendAll(const std::string& data, int timeout_ms);
  // The next complete line of in_, parsed and checked; nullopt when none is complete.
  std::optional<nlohmann::json> takeLine(LineKind* kind);
  [[noreturn]] void closedError() const;

  int fd_ = -1;
  std::string path_;
  std::string in_;
  bool eof_ = false;
  std::int64_t next_id_ = 1;
  std::deque<nlohmann::json> events_;
};

// The emergency stop (`imubench stop`): one connect to stop_socket (empty: control_socket +
// ".stop", and when nothing listens there, control_socket itself: an older daemon), one line,
// and the daemon's reply, raw (ok true or false). Throws ControlError like request(). Shared by
// the CLI's `stop` and the light front end that serves it without loading the CLI
// (tools/imubench_front.cpp).
nlohmann::json sendEmergencyStop(const std::string& control_socket, const std::string& stop_socket);
// What `imubench stop` prints when the daemon took it.
inline constexpr const char* kEmergencyStopSent = "emergency stop sent";
// An ok=false reply throws RemoteError ("error (code): message"), as ControlClient::call.
void throwIfRefused(const nlohmann::json& reply);

}  // namespace imubench::tools
