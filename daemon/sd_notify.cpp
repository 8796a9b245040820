#include "daemon/sd_notify.h"

#include <sys/socket.h>
#include <systemd/sd-daemon.h>

#include <cstring>
#include <string>

namespace imubench::daemon {
namespace {

Status notify(const std::string& state, bool* sent) {
  // unset_environment = 0: helper processes and later calls still find NOTIFY_SOCKET.
  const int rc = ::sd_notify(0, state.c_str());
  if (sent != nullptr) *sent = rc > 0;
  if (rc < 0) return Status::Error("sd_notify(" + state + "): " + std::strerror(-rc));
  return Status::Ok();
}

}  // namespace

Status SystemdNotifier::ready(bool* sent) const {
  return notify("READY=1", sent);
}

Status SystemdNotifier::status(std::string_view text, bool* sent) const {
  // The message is newline-separated VAR=value lines: a newline in the text would let it
  // inject e.g. READY=1 or STOPPING=1, so it becomes a space.
  std::string clean(text);
  for (char& ch : clean)
    if (ch == '\n' || ch == '\r' || ch == '\0') ch = ' ';
  return notify("STATUS=" + clean, sent);
}

Status SystemdNotifier::watchdog(bool* sent) const {
  return notify("WATCHDOG=1", sent);
}

Status SystemdNotifier::stopping(bool* sent) const {
  return notify("STOPPING=1", sent);
}

std::optional<std::chrono::microseconds> SystemdNotifier::watchdogInterval() const {
  std::uint64_t usec = 0;
  if (::sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return std::nullopt;
  return std::chrono::microseconds(usec);
}

Status systemdListenFd(int* fd) {
  *fd = -1;
  // unset_environment = 1: children (e.g. tools the daemon runs) must not think the fds are
  // theirs.
  const int n = ::sd_listen_fds(1);
  if (n < 0) return Status::Error(std::string("sd_listen_fds: ") + std::strerror(-n));
  if (n == 0) return Status::Ok();
  if (n > 1)
    return Status::Error("socket activation passed " + std::to_string(n) +
                         " fds; imubenchd.socket declares exactly one");
  const int candidate = SD_LISTEN_FDS_START;
  if (::sd_is_socket_unix(candidate, SOCK_STREAM, 1, nullptr, 0) <= 0)
    return Status::Error("socket activation fd is not a listening AF_UNIX stream socket");
  *fd = candidate;
  return Status::Ok();
}

}  // namespace imubench::daemon
