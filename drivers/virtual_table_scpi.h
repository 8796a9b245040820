// The virtual table's SCPI-like serial command set on a pseudo-terminal. Commands are
// recognised by the device file's templates, so any command set a device file describes is
// served; replies are the ack, a number for queries, or error_prefix + reason.
#pragma once

#include <atomic>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/faults.h"
#include "drivers/serial_pty.h"
#include "drivers/virtual_world.h"

namespace imubench::drivers {

class VirtualTableScpi {
 public:
  VirtualTableScpi(VirtualWorld& world, const TableDeviceSpec& spec, LinkFaults& faults,
                   EventSink sink);
  ~VirtualTableScpi();
  VirtualTableScpi(const VirtualTableScpi&) = delete;
  VirtualTableScpi& operator=(const VirtualTableScpi&) = delete;

  Status start();
  void stop();
  const std::string& ptyPath() const { return pty_.slavePath(); }
  // Handles one command line and returns the reply line ("" = no reply). Public for tests.
  std::string handle(const std::string& line);

 private:
  enum class Op {
    kModeOff,
    kModePos,
    kModeRate,
    kDemandPos,
    kDemandRate,
    kRotate,
    kStop,
    kEstop,
    kReadPos,
    kReadRate,
    kReadStatus,
    kReadAxisStatus,
    kIlClose,
    kIlOpen,
    kIlReset,
    kSetRateLimit,
    kSetAccelLimit
  };
  struct Pattern {
    Op op;
    std::regex re;
    bool axis, value;
  };
  void run();
  // Applies one recognised command; false + *why when the controller refuses it.
  bool execute(Op op, VirtualTable& table, double t, int axis, double value, std::string* reply,
               std::string* why);

  VirtualWorld& world_;
  TableDeviceSpec spec_;
  LinkFaults& faults_;
  EventSink sink_;
  std::vector<Pattern> patterns_;
  PseudoTerminal pty_;
  std::thread thread_;
  int wake_[2] = {-1, -1};
  std::atomic<bool> stopping_{false};
};

}  // namespace imubench::drivers
