#include "daemon/control_server.h"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

#include "daemon/control_server_internal.h"

namespace imubench::daemon {

namespace control_server_internal {

// strerror_r (GNU: returns the text), not strerror: the daemon's off-loop threads may share
// strerror's buffer.
std::string errnoText(const std::string& what) {
  const int err = errno;
  char buf[256];
  return what + ": " + ::strerror_r(err, buf, sizeof buf);
}

std::string peerText(const PeerCredentials& peer) {
  if (!peer.known) return "";
  return " (uid " + std::to_string(peer.uid) + ", pid " + std::to_string(peer.pid) + ")";
}

}  // namespace control_server_internal

using control_server_internal::errnoText;
using control_server_internal::peerText;

namespace {

constexpr int kAcceptsPerTurn = 16;
// When accept fails for lack of fds or memory, the listening socket stays readable: pausing
// keeps the loop from spinning on it.
constexpr auto kAcceptPause = std::chrono::milliseconds(100);
// The idle check runs four times per idle_timeout_s (a client goes within 1.25 timeouts),
// bounded so a short timeout does not spin and a long one is still checked every minute.
constexpr double kIdleChecksPerTimeout = 4.0;
constexpr double kMinIdleCheckS = 0.05;
constexpr double kMaxIdleCheckS = 60.0;

Status errnoStatus(const std::string& what) {
  return Status::Error(errnoText(what));
}

bool fillAddress(const std::string& path, sockaddr_un* addr) {
  *addr = {};
  addr->sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr->sun_path) return false;
  std::memcpy(addr->sun_path, path.data(), path.size());
  return true;
}

// A stale socket file (its server died) is replaced; a live server or a non-socket is kept.
Status clearStaleSocket(const std::string& path, const sockaddr_un& addr) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0)
    return errno == ENOENT ? Status::Ok() : errnoStatus(path + ": lstat");
  if (!S_ISSOCK(st.st_mode)) return Status::Error(path + ": exists and is not a socket");
  const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (probe < 0) return errnoStatus("socket(AF_UNIX)");
  const int rc = ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int err = errno;
  ::close(probe);
  if (rc == 0) return Status::Error(path + ": another server is listening there");
  if (err != ECONNREFUSED) {
    errno = err;
    return errnoStatus(path + ": probing the existing socket");
  }
  if (::unlink(path.c_str()) != 0 && errno != ENOENT)
    return errnoStatus(path + ": removing the stale socket");
  return Status::Ok();
}

}  // namespace

bool ControlServerOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  sockaddr_un addr{};
  if (listen_fd < 0 && socket_path.empty()) return fail("socket_path: empty (and no listen_fd)");
  if (listen_fd < 0 && socket_path.size() >= sizeof addr.sun_path)
    return fail("socket_path: longer than the 107 bytes AF_UNIX allows");
  if ((socket_mode & ~mode_t{0777}) != 0) return fail("socket_mode: only permission bits 0777");
  if (max_line_bytes < 256) return fail("max_line_bytes: must be >= 256");
  if (max_clients < 1) return fail("max_clients: must be >= 1");
  if (!(idle_timeout_s >= 0.0 && idle_timeout_s <= 1e6))
    return fail("idle_timeout_s: must be in [0, 1e6] s (0: no timeout)");
  if (max_output_bytes < max_line_bytes)
    return fail("max_output_bytes: must be >= max_line_bytes (a reply may quote a request)");
  if (!stop_socket_path.empty() && stop_socket_path.size() >= sizeof addr.sun_path)
    return fail("stop_socket_path: longer than the 107 bytes AF_UNIX allows");
  if (!stop_socket_path.empty() && stop_socket_path == socket_path)
    return fail("stop_socket_path: must differ from socket_path");
  if (max_stop_clients < 1) return fail("max_stop_clients: must be >= 1");
  return true;
}

ControlServer::ControlServer(EventLoop* loop, ControlServerOptions options, Handler handler,
                             const Logger* logger)
    : loop_(loop), options_(std::move(options)), handler_(std::move(handler)), logger_(logger) {}

ControlServer::~ControlServer() {
  while (!clients_.empty()) closeClient(clients_.begin()->first, "server shutting down");
  loop_->cancelTimer(accept_pause_timer_);
  loop_->cancelTimer(idle_timer_);
  for (const int fd : {listen_fd_, stop_listen_fd_}) {
    if (fd < 0) continue;
    loop_->remove(fd);
    ::close(fd);
  }
  struct stat st {};
  if (bound_path_ && ::lstat(options_.socket_path.c_str(), &st) == 0 && st.st_ino == bound_inode_)
    ::unlink(options_.socket_path.c_str());
  if (stop_listen_fd_ >= 0 && ::lstat(options_.stop_socket_path.c_str(), &st) == 0 &&
      st.st_ino == stop_inode_)
    ::unlink(options_.stop_socket_path.c_str());
}

Status ControlServer::start() {
  std::string why;
  if (!options_.IsValid(&why)) return Status::Error("control server options: " + why);
  Status s = options_.listen_fd >= 0 ? adoptListenFd()
                                     : listenOnPath(options_.socket_path, options_.socket_mode,
                                                    &listen_fd_, &bound_inode_);
  if (!s.ok) return s;
  bound_path_ = options_.listen_fd < 0;
  if (Status stop = startStopSocket(); !stop.ok) return stop;
  if (options_.idle_timeout_s > 0.0) {
    const double period =
        std::clamp(options_.idle_timeout_s / kIdleChecksPerTimeout, kMinIdleCheckS, kMaxIdleCheckS);
    const auto ns = std::chrono::nanoseconds(static_cast<std::int64_t>(period * 1e9));
    Status t = loop_->addTimer(
        ns, ns, [this] { closeIdleClients(); }, &idle_timer_);
    if (!t.ok) return t;
  }
  return loop_->add(listen_fd_, EPOLLIN,
                    [this](std::uint32_t) { onListenReadable(listen_fd_, false); });
}

// The stop socket: bound by path (also under socket activation), served first by the loop.
// Its mode is the control socket's (under socket activation: the mode systemd gave that file,
// e.g. SocketMode=0666 to let every local user stop).
Status ControlServer::startStopSocket() {
  if (options_.stop_socket_path.empty()) return Status::Ok();
  mode_t mode = options_.socket_mode;
  struct stat st {};
  if (options_.listen_fd >= 0 && ::stat(options_.socket_path.c_str(), &st) == 0 &&
      S_ISSOCK(st.st_mode))
    mode = st.st_mode & 0777;
  if (Status s = listenOnPath(options_.stop_socket_path, mode, &stop_listen_fd_, &stop_inode_);
      !s.ok)
    return Status::Error("stop socket: " + s.message);
  return loop_->addFirst(stop_listen_fd_, EPOLLIN,
                         [this](std::uint32_t) { onListenReadable(stop_listen_fd_, true); });
}

// *fd is set as soon as the socket exists (the destructor closes it whatever fails after);
// *inode once it is bound (the destructor removes the file only when it is still ours).
Status ControlServer::listenOnPath(const std::string& path, mode_t mode, int* fd, ino_t* inode) {
  sockaddr_un addr{};
  if (!fillAddress(path, &addr)) return Status::Error(path + ": not a usable socket path");
  Status s = clearStaleSocket(path, addr);
  if (!s.ok) return s;
  *fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (*fd < 0) return errnoStatus("socket(AF_UNIX)");
  if (::bind(*fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
    return errnoStatus(path + ": bind");
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) *inode = st.st_ino;
  // chmod between bind and listen: until listen() nobody can connect, so there is no window
  // with the umask's looser mode (and no process-wide umask change).
  if (::chmod(path.c_str(), mode) != 0) return errnoStatus(path + ": chmod");
  if (::listen(*fd, SOMAXCONN) != 0) return errnoStatus(path + ": listen");
  log(LogLevel::kInfo,
      (fd == &stop_listen_fd_ ? "stop socket listening on " : "control socket listening on ") +
          path);
  return Status::Ok();
}

Status ControlServer::adoptListenFd() {
  const int fd = options_.listen_fd;
  int type = 0;
  int listening = 0;
  socklen_t len = sizeof type;
  if (::getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_STREAM)
    return Status::Error("inherited fd " + std::to_string(fd) + ": not a stream socket");
  len = sizeof listening;
  if (::getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &len) != 0 || listening == 0)
    return Status::Error("inherited fd " + std::to_string(fd) + ": not listening");
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0)
    return errnoStatus("inherited fd " + std::to_string(fd) + ": O_NONBLOCK");
  ::fcntl(fd, F_SETFD, FD_CLOEXEC);
  listen_fd_ = fd;
  log(LogLevel::kInfo, "control socket inherited (fd " + std::to_string(fd) + ")");
  return Status::Ok();
}

void ControlServer::onListenReadable(int listen_fd, bool stop) {
  for (int i = 0; i < kAcceptsPerTurn; ++i) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      if (stop) {
        acceptStop(fd);
      } else {
        acceptOne(fd);
      }
      continue;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK) return;
    if (errno == EINTR || errno == ECONNABORTED || errno == EPROTO) continue;
    log(LogLevel::kWarning, errnoText("control socket: accept"));
    pauseAccepting();
    return;
  }
}

void ControlServer::pauseAccepting() {
  if (accept_pause_timer_ >= 0) return;
  const auto listen = [this](std::uint32_t events) {
    for (const int fd : {listen_fd_, stop_listen_fd_})
      if (fd >= 0) (void)loop_->modify(fd, events);
  };
  listen(0);
  const Status s = loop_->addTimer(
      kAcceptPause, std::chrono::nanoseconds(0),
      [this, listen] {
        loop_->cancelTimer(accept_pause_timer_);
        accept_pause_timer_ = -1;
        listen(EPOLLIN);
      },
      &accept_pause_timer_);
  if (!s.ok) listen(EPOLLIN);  // better spinning than deaf
}

void ControlServer::refuseBusy(int fd) {
  ++stats_.refused_busy;
  std::string message = "too many clients (max_clients " + std::to_string(options_.max_clients) +
                        ", " + std::to_string(options_.reserved_clients) +
                        " more reserved for stop/status/ping of root and the command group)";
  if (!options_.stop_socket_path.empty())
    message += "; the emergency stop has its own socket: " + options_.stop_socket_path;
  const std::string line = serializeReply(errorReply(nullptr, ErrorCode::kBusy, message));
  // Best effort: a fresh socket's buffer takes one line; if not, the close says enough.
  [[maybe_unused]] const ssize_t n = ::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
  ::close(fd);
}

namespace {

PeerCredentials peerOf(int fd) {
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) return {};
  return {true, cred.uid, cred.gid, cred.pid};
}

bool sameUid(const PeerCredentials& a, const PeerCredentials& b) {
  return a.known == b.known && (!a.known || a.uid == b.uid);
}

}  // namespace

ControlServer::PeerClass ControlServer::classOf(const PeerCredentials& peer) const {
  if (peer_policy_) return peer_policy_(peer);
  return {true, !peer.known || (peer.uid != 0 && peer.uid != ::geteuid())};
}

// A new connection of peer's uid is coming: if the uid already holds max_connections_per_uid,
// its least recently active one is closed (unless the policy exempts the uid).
void ControlServer::closeLeastActiveOfUid(const PeerCredentials& peer) {
  if (options_.max_connections_per_uid == 0) return;
  std::size_t held = 0;
  const Client* oldest = nullptr;
  for (const auto& [id, c] : clients_) {
    if (c->stop_only || !sameUid(c->peer, peer)) continue;
    ++held;
    if (oldest == nullptr || c->last_active < oldest->last_active) oldest = c.get();
  }
  if (held < options_.max_connections_per_uid || oldest == nullptr) return;
  ++stats_.uid_limit_closes;
  closeClient(oldest->id, "its uid holds max_connections_per_uid (" +
                              std::to_string(options_.max_connections_per_uid) +
                              ") connections: closed, the least recently active, for a new one");
}

void ControlServer::acceptOne(int fd) {
  const PeerCredentials peer = peerOf(fd);
  const PeerClass peer_class = classOf(peer);
  if (peer_class.uid_limited) closeLeastActiveOfUid(peer);
  std::size_t regular = 0;
  std::size_t reserved_held = 0;
  for (const auto& [id, client] : clients_) {
    if (client->stop_only) continue;
    ++(client->reserved ? reserved_held : regular);
  }
  const bool reserved = regular >= options_.max_clients;
  const bool privileged = peer_class.reserved_slots;
  if (reserved && (!privileged || reserved_held >= options_.reserved_clients)) {
    if (!privileged) {
      log(LogLevel::kNotice, "control socket full; a connection" + peerText(peer) +
                                 " refused (reserved slots: root and the command group only)");
    }
    refuseBusy(fd);
    return;
  }
  auto c = std::make_unique<Client>();
  c->id = next_id_++;
  c->fd = fd;
  c->reserved = reserved;
  c->peer = peer;
  const ClientId id = c->id;
  const Status s =
      loop_->add(fd, EPOLLIN, [this, id](std::uint32_t events) { onClientEvent(id, events); });
  if (!s.ok) {
    log(LogLevel::kWarning, "control socket: " + s.message);
    ::close(fd);
    return;
  }
  log(LogLevel::kInfo, "client " + std::to_string(id) + " connected" + peerText(peer) +
                           (reserved ? " into a reserved slot (stop, status, ping)" : ""));
  clients_.emplace(id, std::move(c));
  ++stats_.accepted;
  if (reserved) ++stats_.reserved_accepted;
}

// A connection to the stop socket: always taken (the oldest goes beyond max_stop_clients),
// served first by the loop, and its line read now if it is already there.
void ControlServer::acceptStop(int fd) {
  std::size_t held = 0;
  ClientId oldest = 0;
  for (const auto& [id, c] : clients_) {
    if (!c->stop_only) continue;
    ++held;
    if (oldest == 0) oldest = id;  // ids grow: the first is the oldest
  }
  if (held >= options_.max_stop_clients) closeClient(oldest, "stop socket full: oldest closed");
  auto c = std::make_unique<Client>();
  c->id = next_id_++;
  c->fd = fd;
  c->stop_only = true;
  c->peer = peerOf(fd);
  const ClientId id = c->id;
  if (const Status s = loop_->addFirst(
          fd, EPOLLIN, [this, id](std::uint32_t events) { onClientEvent(id, events); });
      !s.ok) {
    log(LogLevel::kWarning, "stop socket: " + s.message);
    ::close(fd);
    return;
  }
  clients_.emplace(id, std::move(c));
  ++stats_.stop_accepted;
  onClientEvent(id, EPOLLIN);
}

// Closes the clients idle for idle_timeout_s: no request that long, and either no topic or
// output waiting that long unread (a subscriber that reads its events is never idle).
void ControlServer::closeIdleClients() {
  const auto now = std::chrono::steady_clock::now();
  const auto limit = std::chrono::duration<double>(options_.idle_timeout_s);
  std::vector<ClientId> idle;
  for (const auto& [id, c] : clients_) {
    const bool listening = c->topics.any() && c->out_sent == c->out.size();
    if (!listening && now - c->last_active >= limit) idle.push_back(id);
  }
  for (const ClientId id : idle) {
    ++stats_.idle_disconnects;
    closeClient(id, "idle for " + std::to_string(std::lround(options_.idle_timeout_s)) + " s");
  }
}

}  // namespace imubench::daemon
