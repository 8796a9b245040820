// Internals shared by the parts of the control server (daemon/control_server.h): a client's
// state (ControlServer::Client) and two message helpers. Not a public API: only
// daemon/control_server.cpp and daemon/control_server_io.cpp include it.
#pragma once

#include <sys/epoll.h>

#include <bitset>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

#include "daemon/control_server.h"

namespace imubench::daemon {

struct ControlServer::Client {
  ClientId id = 0;
  int fd = -1;
  std::string in;            // the current line so far
  bool discarding = false;   // inside an oversized line: drop bytes up to its newline
  bool read_closed = false;  // the peer shut down its sending side: flush, then close
  std::string out;           // queued output; out_sent bytes of it already written
  std::size_t out_sent = 0;
  std::uint32_t interest = EPOLLIN;  // the events registered with the loop
  std::bitset<kTopicCount> topics;
  bool reserved = false;   // in a reserved slot: stop, status and ping only
  bool stop_only = false;  // on the stop socket: stop only
  PeerCredentials peer;    // SO_PEERCRED at accept
  // The last request received, or output written: what the idle timeout measures from.
  std::chrono::steady_clock::time_point last_active = std::chrono::steady_clock::now();
};

namespace control_server_internal {

// "what: " and errno in words.
std::string errnoText(const std::string& what);

// " (uid U, pid P)" for a known peer, else empty: appended to the lines naming a client.
std::string peerText(const PeerCredentials& peer);

}  // namespace control_server_internal
}  // namespace imubench::daemon
