#include "drivers/modbus_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

namespace imubench::drivers {

namespace {

// Which registers a request writes (function code and its address/count fields).
bool writeRange(const uint8_t* req, int header, int* address, int* count) {
  const uint8_t fn = req[header];
  const int addr = (req[header + 1] << 8) | req[header + 2];
  switch (fn) {
    case 0x06:  // write single register
      *address = addr;
      *count = 1;
      return true;
    case 0x10:  // write multiple registers
      *address = addr;
      *count = (req[header + 3] << 8) | req[header + 4];
      return true;
    case 0x17:  // read/write multiple: write part follows the read part
      *address = (req[header + 5] << 8) | req[header + 6];
      *count = (req[header + 7] << 8) | req[header + 8];
      return true;
    default:
      return false;
  }
}

}  // namespace

ModbusServer::ModbusServer(ModbusDeviceModel& model, LinkFaults& faults, EventSink sink)
    : model_(model), faults_(faults), sink_(std::move(sink)) {}

ModbusServer::~ModbusServer() {
  stop();
}

Status ModbusServer::startTcp(const std::string& host, int port) {
  if (pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    return Status::Error(std::string("pipe: ") + std::strerror(errno));
  }
  mapping_ = modbus_mapping_new(0, 0, model_.holdingCount(), model_.inputCount());
  ctx_ = modbus_new_tcp(host.c_str(), port);
  if (!mapping_ || !ctx_) return Status::Error("cannot create the Modbus TCP server");
  listen_fd_ = modbus_tcp_listen(ctx_, 16);
  if (listen_fd_ < 0) {
    return Status::Error("Modbus TCP listen on " + host + ":" + std::to_string(port) + ": " +
                         modbus_strerror(errno));
  }
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  modbus_set_byte_timeout(ctx_, 0, 500000);
  thread_ = std::thread([this] { runTcp(); });
  return Status::Ok();
}

Status ModbusServer::startRtu(int unit_id) {
  if (pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    return Status::Error(std::string("pipe: ") + std::strerror(errno));
  }
  if (Status s = pty_.open(); !s.ok) return s;
  mapping_ = modbus_mapping_new(0, 0, model_.holdingCount(), model_.inputCount());
  // The device path is never opened: the context works on the pty master set below.
  ctx_ = modbus_new_rtu(pty_.slavePath().c_str(), 115200, 'N', 8, 1);
  if (!mapping_ || !ctx_) return Status::Error("cannot create the Modbus RTU server");
  modbus_set_slave(ctx_, unit_id);
  modbus_set_socket(ctx_, pty_.masterFd());
  modbus_set_byte_timeout(ctx_, 0, 500000);
  thread_ = std::thread([this] { runRtu(); });
  return Status::Ok();
}

void ModbusServer::stop() {
  if (thread_.joinable()) {
    stopping_ = true;
    wait_cv_.notify_all();
    const char b = 's';
    [[maybe_unused]] auto n = ::write(wake_[1], &b, 1);
    thread_.join();
  }
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
  if (ctx_) {
    modbus_set_socket(ctx_, -1);  // the sockets/pty are ours, closed here and by pty_
    modbus_free(ctx_);
  }
  ctx_ = nullptr;
  if (mapping_) modbus_mapping_free(mapping_);
  mapping_ = nullptr;
  for (int& fd : wake_) {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  pty_.close();
}

void ModbusServer::dropConnections() {
  drop_ = true;
  const char b = 'd';
  [[maybe_unused]] auto n = ::write(wake_[1], &b, 1);
}

bool ModbusServer::waitWall(double seconds) {
  std::unique_lock lock(wait_mu_);
  return !wait_cv_.wait_for(lock, std::chrono::duration<double>(seconds),
                            [this] { return stopping_.load(); });
}

void ModbusServer::answer(_modbus* ctx, const uint8_t* query, int rc) {
  if (faults_.drop_replies) {
    emit("virtual Modbus server: fault injection: request dropped without reply");
    return;
  }
  const double delay = faults_.reply_delay_s;
  if (delay > 0) {
    emit("virtual Modbus server: fault injection: reply delayed by " +
         std::to_string(static_cast<int>(delay * 1000)) + " ms");
    if (!waitWall(delay)) return;
  }
  // The link's latency: half on the request's way (the registers are read after it), half
  // on the reply's. A write acts when its reply leaves (modbus_reply stores it), half a round
  // trip later than at a real controller; reads, which stamp the table, are exact.
  const double jitter = faults_.jitter_s;
  double latency = faults_.latency_s;
  if (jitter > 0.0) latency += std::uniform_real_distribution<double>(-jitter, jitter)(rng_);
  latency = std::max(0.0, latency);
  if (latency > 0.0 && !waitWall(0.5 * latency)) return;
  model_.refresh(mapping_);
  if (latency > 0.0 && !waitWall(0.5 * latency)) return;
  // modbus_reply stores a write in the mapping before it sends the reply: a controller acts
  // on a command it received even when its late reply finds the client gone.
  if (modbus_reply(ctx, query, rc, mapping_) == -1) {
    emit(std::string("virtual Modbus server: reply failed: ") + modbus_strerror(errno));
  }
  int address = 0, count = 0;
  if (writeRange(query, modbus_get_header_length(ctx), &address, &count)) {
    model_.written(mapping_, address, count);
  }
}

void ModbusServer::runTcp() {
  std::vector<int> clients;
  uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  auto closeClient = [&](int fd) {
    ::close(fd);
    clients.erase(std::remove(clients.begin(), clients.end(), fd), clients.end());
    clients_ = static_cast<int>(clients.size());
  };
  while (!stopping_) {
    fd_set rd;
    FD_ZERO(&rd);
    FD_SET(listen_fd_, &rd);
    FD_SET(wake_[0], &rd);
    int maxfd = std::max(listen_fd_, wake_[0]);
    for (int fd : clients) {
      FD_SET(fd, &rd);
      maxfd = std::max(maxfd, fd);
    }
    if (select(maxfd + 1, &rd, nullptr, nullptr, nullptr) < 0) {
      if (errno == EINTR) continue;
      emit(std::string("virtual Modbus server: select: ") + std::strerror(errno));
      break;
    }
    if (FD_ISSET(wake_[0], &rd)) {
      char buf[16];
      while (::read(wake_[0], buf, sizeof buf) > 0) {
      }
    }
    if (stopping_) break;
    if (drop_.exchange(false)) {
      emit("virtual Modbus server: fault injection: dropping " + std::to_string(clients.size()) +
           " client connection(s)");
      for (int fd : std::vector<int>(clients)) closeClient(fd);
      continue;
    }
    if (FD_ISSET(listen_fd_, &rd)) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) {
        clients.push_back(fd);
        clients_ = static_cast<int>(clients.size());
      }
    }
    for (int fd : std::vector<int>(clients)) {
      if (!FD_ISSET(fd, &rd)) continue;
      modbus_set_socket(ctx_, fd);
      const int rc = modbus_receive(ctx_, query);
      if (rc > 0) {
        answer(ctx_, query, rc);
      } else if (rc == -1) {
        closeClient(fd);  // client went away or sent garbage
      }
    }
  }
  for (int fd : std::vector<int>(clients)) closeClient(fd);
}

void ModbusServer::runRtu() {
  uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  const int fd = pty_.masterFd();
  while (!stopping_) {
    fd_set rd;
    FD_ZERO(&rd);
    FD_SET(fd, &rd);
    FD_SET(wake_[0], &rd);
    if (select(std::max(fd, wake_[0]) + 1, &rd, nullptr, nullptr, nullptr) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (FD_ISSET(wake_[0], &rd)) {
      char buf[16];
      while (::read(wake_[0], buf, sizeof buf) > 0) {
      }
    }
    if (stopping_) break;
    drop_ = false;  // nothing to drop on a serial line
    if (!FD_ISSET(fd, &rd)) continue;
    const int rc = modbus_receive(ctx_, query);
    if (rc > 0) {
      answer(ctx_, query, rc);
    } else if (rc == -1) {
      modbus_flush(ctx_);  // bad CRC or a partial frame: resynchronise on the next one
    }
  }
}

}  // namespace imubench::drivers
