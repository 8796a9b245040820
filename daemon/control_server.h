// The control socket of imubenchd: a non-blocking AF_UNIX stream socket speaking the NDJSON
// protocol of daemon/control_protocol.h, driven by an EventLoop (one per bench).
//
// The server owns the connections: line framing with a size limit, per-client output queues
// with a bound, subscriptions and event broadcast. It answers ping, subscribe and unsubscribe
// itself (they are about the connection) and hands every other request to the handler, which
// decides the reply (now, or later through sendReply): the server knows nothing of plans or
// benches. A client that does not read its replies is disconnected when its queue overflows;
// the loop never blocks on a client.
//
// Slots: max_clients connections take every command. Beyond them, reserved_clients more are
// accepted for the emergency, only from privileged peers (setReservedPolicy: root and the
// command group in imubenchd): they take only stop, status and ping (anything else: busy). One
// uid holds at most max_connections_per_uid connections (root and the daemon's own uid
// excepted): a new one beyond it closes that uid's least recently active connection, so no
// single user can fill the server. A connection is idle when it has sent no request for
// idle_timeout_s and either listens to no topic or has had output waiting unread that long;
// idle connections are closed. A subscribed watcher that keeps reading its events is never
// idle, however long the bench is quiet.
//
// The stop socket (stop_socket_path): a second socket that takes only stop. Its fds are served
// first on every turn of the loop (EventLoop::addFirst), before the IMU, the table and the
// control socket's clients; a line already there when a connection is accepted is answered at
// once. It has max_stop_clients connections, a new one closing the oldest: holding them never
// locks the stop out. `imubench stop` sends its one line there.
//
// Rights: the server reads each connection's peer credentials (SO_PEERCRED) when it accepts it
// and, before answering any request (ping and subscribe included), asks the access policy it
// was given (setAccessPolicy; daemon/control_rights.h decides for imubenchd) whether that peer
// may send that command; a refusal is answered with the error "forbidden". Without a policy
// every request is allowed.
#pragma once

#include <sys/types.h>

#include <bitset>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "base/status.h"
#include "daemon/control_protocol.h"
#include "daemon/control_rights.h"
#include "daemon/event_loop.h"
#include "daemon/logging.h"

namespace imubench::daemon {

using ClientId = std::uint64_t;  // unique for the server's lifetime (never reused)

struct ControlServerOptions {
  // Where to listen (ignored when listen_fd >= 0). A stale socket file there (nobody
  // listening) is replaced; a live one, or a file that is not a socket, is refused.
  std::string socket_path;
  // An inherited listening AF_UNIX stream socket (systemd socket activation, see
  // systemdListenFd in daemon/sd_notify.h); the server adopts and closes it.
  int listen_fd = -1;
  // Owner and group may command the bench (operators are in the imubench group), others not.
  mode_t socket_mode = 0660;
  // Bounds the memory a client can pin; 64 KiB holds any plan sent inline as TOML.
  std::size_t max_line_bytes = 64 * 1024;
  // A bench has a handful of operator tools attached; more is a leak or abuse.
  std::size_t max_clients = 16;
  // Connections beyond max_clients that take only stop, status and ping: the emergency stop
  // gets through when every regular slot is held. Two: an operator and a safety script.
  std::size_t reserved_clients = 2;
  // A connection without a request for this long (and not a reading subscriber, see above) is
  // closed: leaked connections free their slots. Ten minutes outlasts an operator pausing at a
  // socat prompt; 0 disables the timeout.
  double idle_timeout_s = 600.0;
  // Connections one peer uid may hold (root and the daemon's own uid excepted); beyond it the
  // uid's least recently active connection is closed. 0: no limit.
  std::size_t max_connections_per_uid = 4;
  // The stop socket (the control socket's mode: socket_mode, or under socket activation the
  // inherited socket file's); empty: none.
  std::string stop_socket_path;
  // Its connections at most; a new one beyond this closes the oldest.
  std::size_t max_stop_clients = 8;
  // Replies and events queued for a client that does not read; past this it is disconnected,
  // so one stuck client costs bounded memory and never stalls the loop.
  std::size_t max_output_bytes = 1024 * 1024;
  bool IsValid(std::string* why) const;
};

struct ControlServerStats {
  std::uint64_t accepted = 0;              // connections taken
  std::uint64_t refused_busy = 0;          // connections refused (regular and reserved full)
  std::uint64_t reserved_accepted = 0;     // connections taken into a reserved slot
  std::uint64_t idle_disconnects = 0;      // clients closed after idle_timeout_s
  std::uint64_t overflow_disconnects = 0;  // clients dropped because their queue overflowed
  std::uint64_t requests = 0;              // lines answered (valid or not)
  std::uint64_t errors = 0;                // of which error replies
  std::uint64_t forbidden = 0;             // of which refused by the access policy
  std::uint64_t uid_limit_closes = 0;      // closed for a newer connection of the same uid
  std::uint64_t stop_accepted = 0;         // connections to the stop socket
};

class ControlServer {
 public:
  // Decides the reply to a request (not ping/subscribe/unsubscribe). Runs on the loop's
  // thread; the server sets the reply's id to the request's. May call broadcast()/send().
  // nullopt: the reply comes later (work off the loop thread), through sendReply().
  using Handler = std::function<std::optional<Reply>(const Request&, ClientId)>;
  // Whether a peer may send a command: nullopt allows it, else the refusal's message.
  using AccessPolicy = std::function<std::optional<std::string>(Command, const PeerCredentials&)>;

  // loop and logger (nullable: no logging) must outlive the server.
  ControlServer(EventLoop* loop, ControlServerOptions options, Handler handler,
                const Logger* logger);
  ~ControlServer();  // closes every connection; removes the socket file it created
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Listens (or adopts listen_fd) and registers with the loop.
  Status start();
  // Consulted for every request from now on (empty: allow all).
  void setAccessPolicy(AccessPolicy policy) { policy_ = std::move(policy); }
  // What a connection's peer gets: reserved slots, and whether max_connections_per_uid
  // counts it. Without a policy: every peer may take a reserved slot and every uid but root's
  // and the daemon's own is limited.
  struct PeerClass {
    bool reserved_slots = true;
    bool uid_limited = true;
  };
  using PeerPolicy = std::function<PeerClass(const PeerCredentials&)>;
  void setPeerPolicy(PeerPolicy policy) { peer_policy_ = std::move(policy); }

  // Sends an event to every client subscribed to topic (serialized once).
  void broadcast(Topic topic, std::string_view name, const nlohmann::json& fields = nullptr);
  // The same for an event struct of daemon/control_protocol.h (its kTopic and kEvent).
  template <class E>
  void broadcast(const E& event) {
    broadcast(E::kTopic, E::kEvent, toJson(event));
  }
  // Queues a complete line (newline-terminated) for one client, e.g. a late reply. false when
  // the client is gone or was disconnected because its queue overflowed.
  bool send(ClientId client, std::string_view line);
  // A reply the handler deferred (its id set by the caller); false when the client is gone.
  bool sendReply(ClientId client, const Reply& r);
  // Whether the client is still connected (a deferred reply still has someone to go to).
  bool connected(ClientId client) const { return clients_.count(client) != 0; }

  std::size_t clientCount() const { return clients_.size(); }
  const ControlServerStats& stats() const { return stats_; }

 private:
  struct Client;
  Status listenOnPath(const std::string& path, mode_t mode, int* fd, ino_t* inode);
  Status adoptListenFd();
  Status startStopSocket();
  void onListenReadable(int listen_fd, bool stop);
  void pauseAccepting();
  void acceptOne(int fd);
  void acceptStop(int fd);
  PeerClass classOf(const PeerCredentials& peer) const;
  void closeLeastActiveOfUid(const PeerCredentials& peer);
  void refuseBusy(int fd);
  void closeIdleClients();
  void onClientEvent(ClientId id, std::uint32_t events);
  void serveClient(ClientId id, std::uint32_t events);
  void readFrom(ClientId id);
  void feed(ClientId id, std::string_view data);
  void handleLine(ClientId id, std::string_view line);
  std::optional<Reply> answer(Client& c, const Request& request);
  void reply(ClientId id, const Reply& r);
  bool enqueue(Client& c, std::string_view data);
  bool flush(Client& c);
  void updateInterest(Client& c);
  bool finished(const Client& c) const;
  void closeClient(ClientId id, std::string_view why);
  void log(LogLevel level, const std::string& message) const;

  EventLoop* loop_;
  ControlServerOptions options_;
  Handler handler_;
  AccessPolicy policy_;
  const Logger* logger_;
  PeerPolicy peer_policy_;
  int listen_fd_ = -1;
  bool bound_path_ = false;  // we created socket_path (and remove it at the end)
  ino_t bound_inode_ = 0;    // ...unless someone replaced it since
  int stop_listen_fd_ = -1;  // the stop socket (stop_socket_path), always bound by us
  ino_t stop_inode_ = 0;
  EventLoop::TimerId accept_pause_timer_ = -1;
  EventLoop::TimerId idle_timer_ = -1;
  ClientId next_id_ = 1;
  std::map<ClientId, std::unique_ptr<Client>> clients_;
  ControlServerStats stats_;
};

}  // namespace imubench::daemon
