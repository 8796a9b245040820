#include "drivers/serial_pty.h"

#include <fcntl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace imubench::drivers {

Status PseudoTerminal::open() {
  close();
  master_ = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_ < 0) return Status::Error(std::string("posix_openpt: ") + std::strerror(errno));
  if (grantpt(master_) != 0 || unlockpt(master_) != 0) {
    const std::string m = std::string("grantpt/unlockpt: ") + std::strerror(errno);
    close();
    return Status::Error(m);
  }
  char name[128];
  if (ptsname_r(master_, name, sizeof name) != 0) {
    const std::string m = std::string("ptsname: ") + std::strerror(errno);
    close();
    return Status::Error(m);
  }
  slave_path_ = name;
  slave_keep_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (slave_keep_ < 0) {
    const std::string m = "open " + slave_path_ + ": " + std::strerror(errno);
    close();
    return Status::Error(m);
  }
  termios tio{};
  tcgetattr(slave_keep_, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave_keep_, TCSANOW, &tio);
  return Status::Ok();
}

void PseudoTerminal::close() {
  if (slave_keep_ >= 0) ::close(slave_keep_);
  if (master_ >= 0) ::close(master_);
  slave_keep_ = master_ = -1;
  slave_path_.clear();
}

}  // namespace imubench::drivers
