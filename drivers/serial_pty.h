// A pseudo-terminal pair for virtual serial devices: the virtual device holds the master, a
// driver (or minicom, mbpoll...) opens slavePath() like a real tty. posix_openpt/grantpt/
// unlockpt. The slave is also held open here so the master never sees a hang-up while no
// client is attached, and it is put in raw mode (no echo, no line editing).
#pragma once

#include <string>

#include "drivers/device_errors.h"

namespace imubench::drivers {

class PseudoTerminal {
 public:
  PseudoTerminal() = default;
  ~PseudoTerminal() { close(); }
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  Status open();
  void close();
  int masterFd() const { return master_; }
  const std::string& slavePath() const { return slave_path_; }

 private:
  int master_ = -1;
  int slave_keep_ = -1;
  std::string slave_path_;
};

}  // namespace imubench::drivers
