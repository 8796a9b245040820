// A POSIX serial line (termios): baud, parity, data/stop bits from the device file, raw mode,
// line-oriented exchange with a terminator and a per-request deadline. Works the same on a
// real tty and on a pseudo-terminal slave.
#pragma once

#include <string>
#include <string_view>

#include "drivers/device_errors.h"
#include "drivers/device_file.h"

namespace imubench::drivers {

class SerialPort {
 public:
  SerialPort() = default;
  ~SerialPort() { close(); }
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  Status open(const TransportSpec& t);
  void close();
  bool isOpen() const { return fd_ >= 0; }
  // Writes line + terminator.
  Status writeLine(std::string_view line);
  // Reads up to the terminator (not included) or fails after timeout_s.
  Status readLine(double timeout_s, std::string* line);
  // Drops anything received but not read (a late reply to a timed-out request).
  void discardInput();
  // After a timeout: discards input until the line has been quiet for quiet_s (at most
  // max_s), so a late reply to the timed-out request is not taken for the next one's.
  void drainUntilQuiet(double quiet_s, double max_s);

 private:
  int fd_ = -1;
  std::string terminator_ = "\n";
  std::string buffer_;
};

// termios speed constant for a baud rate (B0 when unsupported).
unsigned baudConstant(int baud);

}  // namespace imubench::drivers
