// Fault injection for the virtual devices' links, set from a test or the virtual-bench
// program while the servers run (atomics: read by the server threads at every request).
#pragma once

#include <atomic>

namespace imubench::drivers {

struct LinkFaults {
  std::atomic<double> reply_delay_s{0.0};  // wall seconds before each reply is sent
  std::atomic<bool> drop_replies{false};   // requests are read but never answered
  // A link's latency (not a fault: a loaded network or gateway): each round trip takes
  // latency_s +- jitter_s (uniform, wall seconds), half on the request's way (before the device
  // reads its registers or acts) and half on the reply's, so the device sampled its values at
  // the round trip's midpoint.
  std::atomic<double> latency_s{0.0};
  std::atomic<double> jitter_s{0.0};

  void clear() {
    reply_delay_s = 0.0;
    drop_replies = false;
    latency_s = 0.0;
    jitter_s = 0.0;
  }
};

}  // namespace imubench::drivers
