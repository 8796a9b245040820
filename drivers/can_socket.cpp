#include "drivers/can_socket.h"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <vector>

namespace imubench::drivers {
namespace {

constexpr std::size_t kBatch = 256;  // frames per sendmmsg / recvmmsg call

std::string errnoText(const std::string& what) {
  return what + ": " + std::strerror(errno);
}

}  // namespace

bool CanSocketOptions::IsValid(std::string* why) const {
  if (receive_buffer_bytes < 0) {
    if (why) *why = "receive_buffer_bytes must be >= 0";
    return false;
  }
  return true;
}

CanSocket::~CanSocket() {
  close();
}

CanSocket::CanSocket(CanSocket&& o) noexcept
    : fd_(o.fd_),
      ifname_(std::move(o.ifname_)),
      fd_frames_(o.fd_frames_),
      kernel_drops_(o.kernel_drops_) {
  o.fd_ = -1;
}

CanSocket& CanSocket::operator=(CanSocket&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    ifname_ = std::move(o.ifname_);
    fd_frames_ = o.fd_frames_;
    kernel_drops_ = o.kernel_drops_;
    o.fd_ = -1;
  }
  return *this;
}

void CanSocket::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Status CanSocket::open(const std::string& ifname, const CanSocketOptions& options) {
  close();
  std::string why;
  if (!options.IsValid(&why)) return Status::Error("CAN socket options: " + why);
  const int s = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (s < 0) return Status::Error(errnoText("CAN " + ifname + ": socket(PF_CAN)"));
  fd_ = s;
  ifname_ = ifname;
  const unsigned index = if_nametoindex(ifname.c_str());
  if (index == 0) {
    close();
    return Status::Error(errnoText("CAN " + ifname + ": no such interface"));
  }
  int one = 1;
  if (options.fd) {
    if (setsockopt(s, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &one, sizeof one) != 0) {
      close();
      return Status::Error(errnoText("CAN " + ifname + ": CAN_RAW_FD_FRAMES"));
    }
    fd_frames_ = true;
  }
  if (options.receive_own) setsockopt(s, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &one, sizeof one);
  if (options.receive_buffer_bytes > 0) {
    const int size = options.receive_buffer_bytes;
    if (setsockopt(s, SOL_SOCKET, SO_RCVBUFFORCE, &size, sizeof size) != 0)
      setsockopt(s, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);  // unprivileged: capped
  }
  if (options.kernel_timestamps) setsockopt(s, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
  setsockopt(s, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (bind(s, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close();
    return Status::Error(errnoText("CAN " + ifname + ": bind"));
  }
  return Status::Ok();
}

Status CanSocket::send(std::span<const CanFrame> frames, std::size_t* sent, int timeout_ms) {
  *sent = 0;
  if (fd_ < 0) return Status::Error("CAN socket not open");
  std::vector<canfd_frame> buf(std::min(frames.size(), kBatch));
  std::vector<iovec> iov(buf.size());
  std::vector<mmsghdr> msgs(buf.size());
  while (*sent < frames.size()) {
    const std::size_t n = std::min(kBatch, frames.size() - *sent);
    for (std::size_t i = 0; i < n; ++i) {
      const CanFrame& f = frames[*sent + i];
      canfd_frame& k = buf[i];
      std::memset(&k, 0, sizeof k);
      k.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0U);
      k.len = f.len;
      std::memcpy(k.data, f.data, f.len);
      if (f.fd && !fd_frames_)
        return Status::Error("CAN " + ifname_ + ": FD frame on a classic socket");
      iov[i].iov_base = &k;
      iov[i].iov_len = f.fd ? CANFD_MTU : CAN_MTU;
      msgs[i] = {};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
    }
    const int r = sendmmsg(fd_, msgs.data(), static_cast<unsigned>(n), 0);
    if (r > 0) {
      *sent += static_cast<std::size_t>(r);
      continue;
    }
    if (r < 0 && errno != ENOBUFS && errno != EAGAIN && errno != EINTR)
      return Status::Error(errnoText("CAN " + ifname_ + ": sendmmsg"));
    // Queue full: wait until writable (state, not a fixed sleep).
    pollfd p{fd_, POLLOUT, 0};
    if (errno != EINTR && poll(&p, 1, timeout_ms) == 0)
      return Status::Error("CAN " + ifname_ + ": send queue stayed full for " +
                           std::to_string(timeout_ms) + " ms");
  }
  return Status::Ok();
}

Status CanSocket::receive(std::span<CanFrame> out, std::size_t* received, int timeout_ms) {
  *received = 0;
  if (fd_ < 0) return Status::Error("CAN socket not open");
  if (out.empty()) return Status::Ok();
  pollfd p{fd_, POLLIN, 0};
  const int pr = poll(&p, 1, timeout_ms);
  if (pr < 0) {
    if (errno == EINTR) return Status::Ok();
    return Status::Error(errnoText("CAN " + ifname_ + ": poll"));
  }
  if (pr == 0) return Status::Ok();
  const std::size_t n = std::min(out.size(), kBatch);
  std::vector<canfd_frame> buf(n);
  std::vector<iovec> iov(n);
  std::vector<mmsghdr> msgs(n);
  constexpr std::size_t kCtl = CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t));
  std::vector<char> ctl(n * kCtl);
  for (std::size_t i = 0; i < n; ++i) {
    iov[i].iov_base = &buf[i];
    iov[i].iov_len = sizeof(canfd_frame);
    msgs[i] = {};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
    msgs[i].msg_hdr.msg_control = ctl.data() + i * kCtl;
    msgs[i].msg_hdr.msg_controllen = kCtl;
  }
  const int r = recvmmsg(fd_, msgs.data(), static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
  if (r < 0) {
    if (errno == EAGAIN || errno == EINTR) return Status::Ok();
    return Status::Error(errnoText("CAN " + ifname_ + ": recvmmsg"));
  }
  for (int i = 0; i < r; ++i) {
    const canfd_frame& k = buf[static_cast<std::size_t>(i)];
    CanFrame& f = out[*received];
    f = CanFrame{};
    f.extended = (k.can_id & CAN_EFF_FLAG) != 0;
    f.id = k.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    f.fd = msgs[static_cast<std::size_t>(i)].msg_len == CANFD_MTU;
    f.len = std::min<std::uint8_t>(k.len, f.fd ? 64 : 8);
    std::memcpy(f.data, k.data, f.len);
    msghdr& h = msgs[static_cast<std::size_t>(i)].msg_hdr;
    for (cmsghdr* c = CMSG_FIRSTHDR(&h); c != nullptr; c = CMSG_NXTHDR(&h, c)) {
      if (c->cmsg_level != SOL_SOCKET) continue;
      if (c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec ts;
        std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
        f.rx_time_s = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
      } else if (c->cmsg_type == SO_RXQ_OVFL) {
        std::memcpy(&kernel_drops_, CMSG_DATA(c), sizeof kernel_drops_);
      }
    }
    // Error frames and remote requests are not IMU data: skip them.
    if (k.can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) continue;
    ++*received;
  }
  return Status::Ok();
}

}  // namespace imubench::drivers
