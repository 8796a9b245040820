// Driver status shared by every device family: what a driver call returns, so callers check
// it (like Ceres' Summary) instead of catching exceptions. External input never crashes.
#pragma once

#include <string>

namespace imubench::drivers {

enum class DeviceState {
  kOffline,   // not connected yet, or connection lost and not re-established
  kReady,     // connected and answering
  kRetrying,  // a request timed out or failed; retrying per the device file's policy
  kFault,     // retries exhausted, interlock open, or device-reported alarm: operator action needed
};

const char* deviceStateName(DeviceState s);

struct Status {
  bool ok = true;
  std::string message;  // empty when ok; otherwise names the device, the request and why
  static Status Ok() { return {}; }
  static Status Error(std::string why) { return {false, std::move(why)}; }
};

}  // namespace imubench::drivers
