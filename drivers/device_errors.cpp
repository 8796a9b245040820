#include "drivers/device_errors.h"

#include <ctime>

namespace imubench::drivers {

const char* deviceStateName(DeviceState s) {
  switch (s) {
    case DeviceState::kOffline:
      return "offline";
    case DeviceState::kReady:
      return "ready";
    case DeviceState::kRetrying:
      return "retrying";
    case DeviceState::kFault:
      return "fault";
  }
  return "unknown";
}

double unixTimeS() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace imubench::drivers
