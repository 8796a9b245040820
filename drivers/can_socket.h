// A raw SocketCAN socket with batched I/O: sendmmsg / recvmmsg (one system call per batch,
// which matters under user-mode-linux where system calls are expensive), a large receive
// buffer (SO_RCVBUFFORCE, falling back to SO_RCVBUF), kernel receive time stamps
// (SO_TIMESTAMPNS) and the kernel's drop counter (SO_RXQ_OVFL). Classic and FD frames.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "drivers/can_frame.h"
#include "drivers/device_errors.h"

namespace imubench::drivers {

struct CanSocketOptions {
  bool fd = true;                       // accept/send CAN FD frames (needs an FD-capable interface)
  int receive_buffer_bytes = 16 << 20;  // large: a slow reader must not lose bursts
  bool kernel_timestamps = true;        // SO_TIMESTAMPNS receive times
  bool receive_own = false;             // see frames this socket sent (normally not wanted)
  bool IsValid(std::string* why) const;
};

class CanSocket {
 public:
  CanSocket() = default;
  ~CanSocket();
  CanSocket(CanSocket&& o) noexcept;
  CanSocket& operator=(CanSocket&& o) noexcept;
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  // Opens and binds a raw CAN socket on interface ifname (e.g. "vcan0").
  Status open(const std::string& ifname, const CanSocketOptions& options);
  bool isOpen() const { return fd_ >= 0; }
  void close();
  int fd() const { return fd_; }

  // Sends all frames in batches (sendmmsg). When the interface queue is full it waits for
  // the socket to become writable (up to timeout_ms per wait). *sent = frames sent.
  Status send(std::span<const CanFrame> frames, std::size_t* sent, int timeout_ms = 1000);
  // Waits up to timeout_ms for frames, then receives up to out.size() of them in one batch
  // (recvmmsg), filling rx_time_s. *received may be 0 on timeout (not an error).
  Status receive(std::span<CanFrame> out, std::size_t* received, int timeout_ms);
  // Frames the kernel dropped because our receive queue was full (SO_RXQ_OVFL), cumulative.
  std::uint32_t kernelDrops() const { return kernel_drops_; }

 private:
  int fd_ = -1;
  std::string ifname_;
  bool fd_frames_ = false;
  std::uint32_t kernel_drops_ = 0;
};

}  // namespace imubench::drivers
