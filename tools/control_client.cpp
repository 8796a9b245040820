#include "tools/control_client.h"

#include <grp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <utility>
#include <vector>

namespace imubench::tools {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

// Milliseconds left until deadline for poll(); -1 (forever) when there is no deadline.
int msLeft(const std::optional<Clock::time_point>& deadline) {
  if (!deadline) return -1;
  const auto left =
      std::chrono::duration_cast<std::chrono::milliseconds>(*deadline - Clock::now()).count();
  return left > 0 ? static_cast<int>(left) : 0;
}

std::optional<Clock::time_point> deadlineAfter(int timeout_ms) {
  if (timeout_ms < 0) return std::nullopt;
  return Clock::now() + std::chrono::milliseconds(timeout_ms);
}

// A line quoted in an error: bounded, and readable when it holds binary garbage.
std::string quoteLine(std::string_view line) {
  constexpr std::size_t kMax = 120;
  std::string out = "\"";
  for (std::size_t i = 0; i < line.size() && i < kMax; ++i) {
    const auto ch = static_cast<unsigned char>(line[i]);
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += static_cast<char>(ch);
    } else if (ch < 0x20 || ch >= 0x7f) {
      static const char* kHex = "0123456789abcdef";
      out += "\\x";
      out += kHex[ch >> 4];
      out += kHex[ch & 0xf];
    } else {
      out += static_cast<char>(ch);
    }
  }
  out += '"';
  if (line.size() > kMax) out += " (" + std::to_string(line.size()) + " bytes)";
  return out;
}

std::string errnoText(int err) {
  return std::strerror(err);
}

// A group's name, or its number when the group database has none.
std::string groupName(gid_t gid) {
  std::vector<char> buf(64 * 1024);
  group gr{};
  group* found = nullptr;
  if (::getgrgid_r(gid, &gr, buf.data(), buf.size(), &found) == 0 && found != nullptr)
    return gr.gr_name;
  return std::to_string(gid);
}

// Why a connect was refused for lack of rights: the group that owns the socket (or the first
// directory on its way that this user cannot pass), as the bench's installation set it.
std::string permissionHint(const std::string& path) {
  struct stat st {};
  std::filesystem::path p(path);
  while (::stat(p.c_str(), &st) != 0 && p.has_parent_path() && p != p.parent_path())
    p = p.parent_path();
  if (::stat(p.c_str(), &st) != 0) return "may you use the bench? ";
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
  const std::string group = groupName(st.st_gid);
  return "may you use the bench? " + p.string() + " is mode " + mode + ", group " + group +
         " (are you in group " + group + "?); ";
}

}  // namespace

std::string defaultControlSocket() {
  const char* env = std::getenv("IMUBENCH_SOCKET");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string(kDefaultControlSocket);
}

RemoteError::RemoteError(std::string code, std::string message)
    : ControlError(Kind::kRemote, "error (" + code + "): " + message),
      code_(std::move(code)),
      message_(std::move(message)) {}

ControlClient::~ControlClient() {
  close();
}

void ControlClient::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  in_.clear();
  eof_ = false;
}

void ControlClient::connect(const std::string& path) {
  close();
  path_ = path;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    throw ControlError(ControlError::Kind::kConnect,
                       "socket " + quoteLine(path) + ": not a usable socket path (empty or over " +
                           std::to_string(sizeof addr.sun_path - 1) + " bytes)");
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    throw ControlError(ControlError::Kind::kConnect, "socket(): " + errnoText(errno));
  }
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    std::string hint = "is imubenchd running? ";
    if (err == EACCES || err == EPERM) hint = permissionHint(path);
    throw ControlError(ControlError::Kind::kConnect,
                       hint + "socket " + path + ": " + errnoText(err));
  }
  fd_ = fd;
}

void ControlClient::closedError() const {
  std::string msg = "imubenchd closed the connection (socket " + path_ + ")";
  if (!in_.empty()) msg += " in the middle of a line: " + quoteLine(in_);
  throw ControlError(ControlError::Kind::kClosed, msg);
}

void ControlClient::sendAll(const std::string& data, int timeout_ms) {
  const auto deadline = deadlineAfter(timeout_ms);
  std::size_t sent = 0;
  while (sent < data.size()) {
    pollfd p{fd_, POLLOUT, 0};
    const int n = ::poll(&p, 1, msLeft(deadline));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ControlError(ControlError::Kind::kIo, "poll: " + errnoText(errno));
    if (n == 0) {
      throw ControlError(ControlError::Kind::kTimeout,
                         "imubenchd did not take the request within " + std::to_string(timeout_ms) +
                             " ms (socket " + path_ + ")");
    }
    const ssize_t w =
        ::send(fd_, data.data() + sent, data.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (w < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      if (errno == EPIPE || errno == ECONNRESET) closedError();
      throw ControlError(ControlError::Kind::kIo,
                         "sending to socket " + path_ + ": " + errnoText(errno));
    }
    sent += static_cast<std::size_t>(w);
  }
}

bool ControlClient::readSome(int timeout_ms) {
  if (eof_) closedError();
  const auto deadline = deadlineAfter(timeout_ms);
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    const int n = ::poll(&p, 1, msLeft(deadline));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ControlError(ControlError::Kind::kIo, "poll: " + errnoText(errno));
    if (n == 0) return false;
    char buf[65536];
    const ssize_t r = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (r > 0) {
      in_.append(buf, static_cast<std::size_t>(r));
      return true;
    }
    if (r == 0) {
      eof_ = true;
      closedError();
    }
    if (errno == EAGAIN || errno == EINTR) continue;
    if (errno == ECONNRESET) {
      eof_ = true;
      closedError();
    }
    throw ControlError(ControlError::Kind::kIo,
                       "reading socket " + path_ + ": " + errnoText(errno));
  }
}

std::optional<json> ControlClient::takeLine(LineKind* kind) {
  for (;;) {
    const auto nl = in_.find('\n');
    if (nl == std::string::npos) {
      if (in_.size() > kMaxLineBytes) {
        throw ControlError(ControlError::Kind::kProtocol, "imubenchd sent a line over " +
                                                              std::to_string(kMaxLineBytes) +
                                                              " bytes: " + quoteLine(in_));
      }
      return std::nullopt;
    }
    std::string line = in_.substr(0, nl);
    in_.erase(0, nl + 1);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;  // blank
    json j = json::parse(line, nullptr, false);
    if (j.is_discarded()) {
      throw ControlError(ControlError::Kind::kProtocol,
                         "imubenchd sent a line that is not JSON: " + quoteLine(line));
    }
    if (j.is_object() && j.contains("event") && j["event"].is_string()) {
      *kind = LineKind::kEvent;
      return j;
    }
    if (j.is_object() && j.contains("ok") && j["ok"].is_boolean()) {
      const bool ok = j["ok"].get<bool>();
      const bool shaped = ok ? (!j.contains("result") || j["result"].is_object())
                             : (j.contains("error") && j["error"].is_object());
      if (shaped) {
        *kind = LineKind::kReply;
        return j;
      }
    }
    throw ControlError(
        ControlError::Kind::kProtocol,
        "imubenchd sent a line that is neither a reply nor an event: " + quoteLine(line));
  }
}

json ControlClient::request(json req, int timeout_ms) {
  if (fd_ < 0) throw ControlError(ControlError::Kind::kIo, "not connected");
  if (!req.is_object() || !req.contains("cmd")) {
    throw ControlError(ControlError::Kind::kIo, "a request is an object with \"cmd\"");
  }
  if (!req.contains("id")) req["id"] = next_id_++;
  const json id = req["id"];
  sendAll(req.dump(-1, ' ', false, json::error_handler_t::replace) + "\n", timeout_ms);
  const auto deadline = deadlineAfter(timeout_ms);
  for (;;) {
    LineKind kind = LineKind::kReply;
    while (auto line = takeLine(&kind)) {
      if (kind == LineKind::kEvent) {
        events_.push_back(std::move(*line));
        continue;
      }
      const json& rid = (*line)["id"];
      if (rid == id) return std::move(*line);
      // The server could not read the request's id (a line it refused as too large): as we
      // have one request in flight, that error is the answer to it.
      if (rid.is_null() && !(*line)["ok"].get<bool>()) return std::move(*line);
      // else: a late reply to a request that timed out earlier; dropped.
    }
    if (!readSome(msLeft(deadline))) {
      throw ControlError(ControlError::Kind::kTimeout,
                         "no reply from imubenchd to " + req["cmd"].dump() + " within " +
                             std::to_string(timeout_ms) + " ms (socket " + path_ + ")");
    }
  }
}

json ControlClient::call(json req, int timeout_ms) {
  json reply = request(std::move(req), timeout_ms);
  throwIfRefused(reply);
  return reply.contains("result") ? reply["result"] : json::object();
}

void throwIfRefused(const json& reply) {
  if (reply["ok"].get<bool>()) return;
  const json& e = reply["error"];
  const std::string code =
      e.contains("code") && e["code"].is_string() ? e["code"].get<std::string>() : "?";
  const std::string message = e.contains("message") && e["message"].is_string()
                                  ? e["message"].get<std::string>()
                                  : e.dump(-1, ' ', false, json::error_handler_t::replace);
  throw RemoteError(code, message);
}

std::optional<json> ControlClient::nextEvent(int timeout_ms) {
  if (!events_.empty()) {
    json ev = std::move(events_.front());
    events_.pop_front();
    return ev;
  }
  if (fd_ < 0) throw ControlError(ControlError::Kind::kIo, "not connected");
  const auto deadline = deadlineAfter(timeout_ms);
  for (;;) {
    LineKind kind = LineKind::kReply;
    while (auto line = takeLine(&kind)) {
      if (kind == LineKind::kEvent) return line;
    }
    if (!readSome(msLeft(deadline))) return std::nullopt;
  }
}

json sendEmergencyStop(const std::string& control_socket, const std::string& stop_socket) {
  ControlClient c;
  try {
    c.connect(stop_socket.empty() ? control_socket + ".stop" : stop_socket);
  } catch (const ControlError&) {
    if (!stop_socket.empty()) throw;
    c.connect(control_socket);  // no stop socket at the default path: the control socket
  }
  return c.request({{"cmd", "stop"}});
}

}  // namespace imubench::tools
