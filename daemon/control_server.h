// The control socket of imubenchd: a non-blocking AF_UNIX stream socket speaking the NDJSON
// protocol of daemon/control_protocol.h, driven by an EventLoop (one per bench).
//
// The server owns the connections: line framing with a size limit, per-client output queues
// with a bound, subscriptions and event broadcast. It answers ping, subscribe and unsubscribe
// itself (they are about the connection) and hands every other request to the handler, which
// decides the reply: the server knows nothing of plans or benches. A client that does not read
// its replies is disconnected when its queue overflows; the loop never blocks on a client.
#pragma once

#include <sys/types.h>

#include <bitset>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "daemon/control_protocol.h"
#include "daemon/event_loop.h"
#include "daemon/io_status.h"
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
  // Replies and events queued for a client that does not read; past this it is disconnected,
  // so one stuck client costs bounded memory and never stalls the loop.
  std::size_t max_output_bytes = 1024 * 1024;
  bool IsValid(std::string* why) const;
};

struct ControlServerStats {
  std::uint64_t accepted = 0;              // connections taken
  std::uint64_t refused_busy = 0;          // connections refused at max_clients
  std::uint64_t overflow_disconnects = 0;  // clients dropped because their queue overflowed
  std::uint64_t requests = 0;              // lines answered (valid or not)
  std::uint64_t errors = 0;                // of which error replies
};

class ControlServer {
 public:
  // Decides the reply to a request (not ping/subscribe/unsubscribe). Runs on the loop's
  // thread; the server sets the reply's id to the request's. May call broadcast()/send().
  using Handler = std::function<Reply(const Request&, ClientId)>;

  // loop and logger (nullable: no logging) must outlive the server.
  ControlServer(EventLoop* loop, ControlServerOptions options, Handler handler,
                const Logger* logger);
  ~ControlServer();  // closes every connection; removes the socket file it created
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Listens (or adopts listen_fd) and registers with the loop.
  IoStatus start();

  // Sends an event to every client subscribed to topic (serialized once).
  void broadcast(Topic topic, std::string_view name, const nlohmann::json& fields = nullptr);
  // Queues a complete line (newline-terminated) for one client, e.g. a late reply. false when
  // the client is gone or was disconnected because its queue overflowed.
  bool send(ClientId client, std::string_view line);

  std::size_t clientCount() const { return clients_.size(); }
  const ControlServerStats& stats() const { return stats_; }

 private:
  struct Client;
  IoStatus listenOnPath();
  IoStatus adoptListenFd();
  void onListenReadable();
  void pauseAccepting();
  void acceptOne(int fd);
  void onClientEvent(ClientId id, std::uint32_t events);
  void readFrom(ClientId id);
  void feed(ClientId id, std::string_view data);
  void handleLine(ClientId id, std::string_view line);
  Reply answer(Client& c, const Request& request);
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
  const Logger* logger_;
  int listen_fd_ = -1;
  bool bound_path_ = false;  // we created socket_path (and remove it at the end)
  ino_t bound_inode_ = 0;    // ...unless someone replaced it since
  EventLoop::TimerId accept_pause_timer_ = -1;
  ClientId next_id_ = 1;
  std::map<ClientId, std::unique_ptr<Client>> clients_;
  ControlServerStats stats_;
};

}  // namespace imubench::daemon
