// Fault injection for the virtual devices' links, set from a test or the virtual-bench
// program while the servers run (atomics: read by the server threads at every request).
#pragma once

#include <atomic>

namespace imubench::drivers {

struct LinkFaults {
  std::atomic<double> reply_delay_s{0.0};  // wall seconds before each reply is sent
  std::atomic<bool> drop_replies{false};   // requests are read but never answered

  void clear() {
    reply_delay_s = 0.0;
    drop_replies = false;
  }
};

}  // namespace imubench::drivers
