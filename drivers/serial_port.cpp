#include "drivers/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace imubench::drivers {

unsigned baudConstant(int baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    default:
      return B0;
  }
}

Status SerialPort::open(const TransportSpec& t) {
  close();
  terminator_ = t.terminator;
  buffer_.clear();
  const int fd = ::open(t.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return Status::Error("cannot open " + t.device + ": " + std::strerror(errno));
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) {
    const std::string m = "not a serial line: " + t.device + ": " + std::strerror(errno);
    ::close(fd);
    return Status::Error(m);
  }
  cfmakeraw(&tio);
  const speed_t speed = baudConstant(t.baud);
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag |= t.data_bits == 5 ? CS5 : t.data_bits == 6 ? CS6 : t.data_bits == 7 ? CS7 : CS8;
  if (t.parity == 'E') tio.c_cflag |= PARENB;
  if (t.parity == 'O') tio.c_cflag |= PARENB | PARODD;
  if (t.stop_bits == 2) tio.c_cflag |= CSTOPB;
  if (tcsetattr(fd, TCSANOW, &tio) != 0) {
    const std::string m = "cannot configure " + t.device + ": " + std::strerror(errno);
    ::close(fd);
    return Status::Error(m);
  }
  fd_ = fd;
  return Status::Ok();
}

void SerialPort::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  buffer_.clear();
}

Status SerialPort::writeLine(std::string_view line) {
  if (fd_ < 0) return Status::Error("serial line not open");
  std::string out(line);
  out += terminator_;
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::write(fd_, out.data() + done, out.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN) {
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
        continue;
      }
      return Status::Error(std::string("write failed: ") + std::strerror(errno));
    }
    done += static_cast<size_t>(n);
  }
  return Status::Ok();
}

Status SerialPort::readLine(double timeout_s, std::string* line) {
  if (fd_ < 0) return Status::Error("serial line not open");
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const auto pos = buffer_.find(terminator_);
    if (pos != std::string::npos) {
      *line = buffer_.substr(0, pos);
      buffer_.erase(0, pos + terminator_.size());
      return Status::Ok();
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return Status::Error("no reply within the timeout");
    pollfd p{fd_, POLLIN, 0};
    const int rc = ::poll(&p, 1, static_cast<int>(left));
    if (rc < 0 && errno != EINTR)
      return Status::Error(std::string("poll: ") + std::strerror(errno));
    if (rc <= 0) continue;
    if (p.revents & (POLLERR | POLLNVAL)) return Status::Error("serial line error");
    char buf[256];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0) {
      buffer_.append(buf, static_cast<size_t>(n));
      if (buffer_.size() > 4096) return Status::Error("reply too long without a terminator");
    } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
      return Status::Error(std::string("read failed: ") + std::strerror(errno));
    } else if (p.revents & POLLHUP) {
      return Status::Error("serial line hung up");
    }
  }
}

void SerialPort::drainUntilQuiet(double quiet_s, double max_s) {
  buffer_.clear();
  if (fd_ < 0) return;
  using Clock = std::chrono::steady_clock;
  const auto end = Clock::now() + std::chrono::duration<double>(max_s);
  while (Clock::now() < end) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(quiet_s * 1000)) <= 0) return;  // quiet (or error)
    char buf[256];
    if (::read(fd_, buf, sizeof buf) <= 0) return;
  }
}

void SerialPort::discardInput() {
  buffer_.clear();
  if (fd_ >= 0) tcflush(fd_, TCIFLUSH);
}

}  // namespace imubench::drivers
