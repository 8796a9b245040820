// The daemon's side of systemd: readiness, status text and watchdog pings over sd_notify(3),
// and the control socket handed over by socket activation (sd_listen_fds(3)). Outside systemd
// (no NOTIFY_SOCKET / LISTEN_FDS) every call is a successful no-op, so the same binary runs in
// the foreground for development.
#pragma once

#include <chrono>
#include <optional>
#include <string_view>

#include "base/status.h"

namespace imubench::daemon {

class SystemdNotifier {
 public:
  // Each returns an error only when NOTIFY_SOCKET is set and sending failed; *sent (optional)
  // tells whether a message went out (false outside systemd).
  Status ready(bool* sent = nullptr) const;  // READY=1: the control socket is up
  Status status(std::string_view text, bool* sent = nullptr) const;  // STATUS=text
  Status watchdog(bool* sent = nullptr) const;  // WATCHDOG=1: the loop is alive
  Status stopping(bool* sent = nullptr) const;  // STOPPING=1: orderly shutdown begun

  // WatchdogSec= of the unit when the watchdog is enabled for this process (WATCHDOG_USEC and
  // WATCHDOG_PID): ping at half of it. nullopt when disabled.
  std::optional<std::chrono::microseconds> watchdogInterval() const;
};

// The listening control socket passed by systemd (imubenchd.socket): its fd, or -1 when the
// process was not socket-activated. Exactly one AF_UNIX stream socket is expected; anything
// else is an error (a unit misconfiguration).
Status systemdListenFd(int* fd);

}  // namespace imubench::daemon
