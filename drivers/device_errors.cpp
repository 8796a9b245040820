#include "drivers/device_errors.h"

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

}  // namespace imubench::drivers
