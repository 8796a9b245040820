// The control server's client side (daemon/control_server.h): reading a client's lines, answering
// them, queueing and flushing its output, events to subscribers, closing it.

#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>

#include "daemon/control_server.h"
#include "daemon/control_server_internal.h"

namespace imubench::daemon {

using control_server_internal::errnoText;
using control_server_internal::peerText;

namespace {

// Per wake-up, a client's bytes are read in slices of kReadChunk up to kReadPerTurn: a flooding
// client is served again next turn (level-triggered) after the others had theirs.
constexpr std::size_t kReadChunk = std::size_t{16} * 1024;
constexpr std::size_t kReadPerTurn = std::size_t{256} * 1024;

// What a client in a reserved slot may send: enough to stop the bench and see that it stopped.
bool reservedCommand(Command c) {
  return c == Command::kStop || c == Command::kStatus || c == Command::kPing;
}

}  // namespace

// A client's input never takes the loop down: whatever throws while serving it (the parser
// and the handler catch their own; this is for the rest, e.g. bad_alloc) closes that client.
void ControlServer::onClientEvent(ClientId id, std::uint32_t events) {
  try {
    serveClient(id, events);
  } catch (const std::exception& e) {
    log(LogLevel::kError, "client " + std::to_string(id) + ": " + e.what() + "; closing it");
    closeClient(id, "internal error");
  }
}

void ControlServer::serveClient(ClientId id, std::uint32_t events) {
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  if ((events & EPOLLOUT) != 0 && !flush(*it->second)) {
    closeClient(id, "write failed");
    return;
  }
  if (finished(*it->second)) {
    closeClient(id, "disconnected");
    return;
  }
  if ((events & (EPOLLIN | EPOLLHUP | EPOLLERR)) != 0) readFrom(id);
}

void ControlServer::readFrom(ClientId id) {
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): read() fills what it uses
  std::array<char, kReadChunk> buf;
  for (std::size_t total = 0; total < kReadPerTurn;) {
    auto it = clients_.find(id);
    if (it == clients_.end() || it->second->read_closed) return;
    Client& c = *it->second;
    const ssize_t n = ::recv(c.fd, buf.data(), buf.size(), 0);
    if (n > 0) {
      total += static_cast<std::size_t>(n);
      feed(id, std::string_view(buf.data(), static_cast<std::size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n < 0) {
      closeClient(id, errnoText("recv"));
      return;
    }
    // EOF: a last line without its newline still counts; replies still go out (socat-style
    // clients half-close after sending).
    c.read_closed = true;
    if (!c.discarding && !c.in.empty()) {
      const std::string last = std::move(c.in);
      c.in.clear();
      handleLine(id, last);
    }
    it = clients_.find(id);
    if (it == clients_.end()) return;
    if (finished(*it->second)) {
      closeClient(id, "disconnected");
    } else {
      updateInterest(*it->second);
    }
    return;
  }
}

void ControlServer::feed(ClientId id, std::string_view data) {
  while (!data.empty()) {
    const auto it = clients_.find(id);
    if (it == clients_.end()) return;  // a handler's broadcast overflowed this client
    Client& c = *it->second;
    const std::size_t nl = data.find('\n');
    const std::string_view part = data.substr(0, nl);
    if (!c.discarding && c.in.size() + part.size() > options_.max_line_bytes) {
      c.in.clear();
      c.discarding = true;
      reply(id, errorReply(nullptr, ErrorCode::kTooLarge,
                           "line longer than max_line_bytes (" +
                               std::to_string(options_.max_line_bytes) + "); discarded"));
      continue;  // re-find: the reply may have overflowed the client's queue
    }
    if (!c.discarding) c.in.append(part);
    if (nl == std::string_view::npos) return;
    data.remove_prefix(nl + 1);
    if (c.discarding) {
      c.discarding = false;  // the oversized line ended here
      continue;
    }
    const std::string line = std::move(c.in);
    c.in.clear();
    handleLine(id, line);
  }
}

void ControlServer::handleLine(ClientId id, std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);  // telnet-style clients
  if (line.find_first_not_of(" \t") == std::string_view::npos) return;
  const ParseResult parsed = parseRequest(line);
  if (!parsed.ok) {
    reply(id, errorReply(parsed.id, parsed.error.code, parsed.error.message));
    return;
  }
  const auto it = clients_.find(id);
  if (it == clients_.end()) return;
  it->second->last_active = std::chrono::steady_clock::now();
  std::optional<Reply> r = answer(*it->second, parsed.request);
  if (!r) return;  // deferred: the handler answers through sendReply
  r->id = parsed.request.id;
  reply(id, *r);
}

std::optional<Reply> ControlServer::answer(Client& c, const Request& request) {
  if (c.stop_only && request.command != Command::kStop) {
    return errorReply(request.id, ErrorCode::kBadArgument,
                      "the stop socket takes only {\"cmd\":\"stop\"} (everything else: the "
                      "control socket " +
                          options_.socket_path + ")");
  }
  if (c.stop_only)
    log(LogLevel::kNotice, "emergency stop through the stop socket" + peerText(c.peer));
  if (c.reserved && !reservedCommand(request.command)) {
    return errorReply(request.id, ErrorCode::kBusy,
                      "all " + std::to_string(options_.max_clients) +
                          " client slots are taken; this connection is in a reserved slot and "
                          "takes only stop, status and ping");
  }
  if (policy_) {
    if (auto refused = policy_(request.command, c.peer)) {
      ++stats_.forbidden;
      log(LogLevel::kNotice, "client " + std::to_string(c.id) + ": " + *refused);
      return errorReply(request.id, ErrorCode::kForbidden, *refused);
    }
  }
  switch (request.command) {
    case Command::kPing:
      return okReply(request.id, toJson(PingReply{true}));
    case Command::kSubscribe:
    case Command::kUnsubscribe: {
      const bool on = request.command == Command::kSubscribe;
      const auto& topics = on ? std::get<SubscribeArgs>(request.args).topics
                              : std::get<UnsubscribeArgs>(request.args).topics;
      if (!on && topics.empty()) c.topics.reset();
      for (const Topic t : topics) c.topics.set(static_cast<std::size_t>(t), on);
      TopicsReply now;
      for (int t = 0; t < kTopicCount; ++t) {
        if (c.topics.test(static_cast<std::size_t>(t)))
          now.topics.emplace_back(topicName(Topic(t)));
      }
      return okReply(request.id, toJson(now));
    }
    default:
      break;
  }
  try {
    return handler_(request, c.id);
  } catch (const std::exception& e) {
    // The handler is daemon code that should return errors; this keeps one bug from
    // taking the whole bench's loop down.
    log(LogLevel::kError, std::string("control handler threw: ") + e.what());
    return errorReply(request.id, ErrorCode::kInternal, "internal error");
  }
}

void ControlServer::reply(ClientId id, const Reply& r) {
  ++stats_.requests;
  if (!r.ok) ++stats_.errors;
  send(id, serializeReply(r));
}

bool ControlServer::sendReply(ClientId client, const Reply& r) {
  if (!connected(client)) return false;
  reply(client, r);
  return connected(client);
}

bool ControlServer::send(ClientId client, std::string_view line) {
  const auto it = clients_.find(client);
  if (it == clients_.end()) return false;
  if (enqueue(*it->second, line)) {
    if (finished(*it->second)) closeClient(client, "disconnected");
    return true;
  }
  ++stats_.overflow_disconnects;
  closeClient(client, "output queue overflow (client does not read)");
  return false;
}

void ControlServer::broadcast(Topic topic, std::string_view name, const nlohmann::json& fields) {
  const std::string line = serializeEvent(topic, name, fields);
  std::vector<ClientId> overflowed;
  for (auto& [id, c] : clients_) {
    if (c->topics.test(static_cast<std::size_t>(topic)) && !enqueue(*c, line))
      overflowed.push_back(id);
  }
  for (const ClientId id : overflowed) {
    ++stats_.overflow_disconnects;
    closeClient(id, "output queue overflow (client does not read)");
  }
  std::vector<ClientId> done;
  for (auto& [id, c] : clients_)
    if (finished(*c)) done.push_back(id);
  for (const ClientId id : done) closeClient(id, "disconnected");
}

// Writes what it can now and queues the rest; false when the queue would exceed its bound or
// the socket failed (the caller closes the client).
bool ControlServer::enqueue(Client& c, std::string_view data) {
  if (c.out.size() - c.out_sent + data.size() > options_.max_output_bytes) return false;
  c.out.append(data);
  return flush(c);
}

bool ControlServer::flush(Client& c) {
  while (c.out_sent < c.out.size()) {
    const ssize_t n = ::send(c.fd, c.out.data() + c.out_sent, c.out.size() - c.out_sent,
                             MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      c.out_sent += static_cast<std::size_t>(n);
      c.last_active = std::chrono::steady_clock::now();
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    return false;  // EPIPE / ECONNRESET: the peer is gone
  }
  if (c.out_sent == c.out.size()) {
    c.out.clear();
    c.out_sent = 0;
  } else if (c.out_sent > c.out.size() / 2) {
    c.out.erase(0, c.out_sent);  // keep the buffer from growing by its sent prefix
    c.out_sent = 0;
  }
  updateInterest(c);
  return true;
}

void ControlServer::updateInterest(Client& c) {
  const bool pending = c.out_sent < c.out.size();
  const std::uint32_t events =
      (c.read_closed ? 0u : std::uint32_t{EPOLLIN}) | (pending ? std::uint32_t{EPOLLOUT} : 0u);
  if (events == c.interest) return;
  c.interest = events;
  (void)loop_->modify(c.fd, events);
}

// After the peer's EOF, a client lives only until its queue is written.
bool ControlServer::finished(const Client& c) const {
  return c.read_closed && c.out_sent == c.out.size();
}

void ControlServer::closeClient(ClientId id, std::string_view why) {
  const auto it = clients_.find(id);
  if (it == clients_.end()) return;
  loop_->remove(it->second->fd);
  ::close(it->second->fd);
  clients_.erase(it);
  log(LogLevel::kInfo, "client " + std::to_string(id) + ": " + std::string(why));
}

void ControlServer::log(LogLevel level, const std::string& message) const {
  if (logger_ != nullptr) logger_->log(level, message);
}

}  // namespace imubench::daemon
