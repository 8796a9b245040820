// Device state shared by every device family. A driver call returns imubench::Status
// (base/status.h) naming the device, the request and why, so callers check it instead of
// catching exceptions. External input never crashes. unixTimeS stamps readings.
#pragma once

#include <functional>
#include <string>

#include "base/status.h"

namespace imubench::drivers {

enum class DeviceState {
  kOffline,   // not connected yet, or connection lost and not re-established
  kReady,     // connected and answering
  kRetrying,  // a request timed out or failed; retrying per the device file's policy
  kFault,     // retries exhausted, interlock open, or device-reported alarm: operator action needed
};

const char* deviceStateName(DeviceState s);

// The end of a reading: `fault` is what the device reports now (empty: nothing). A fault is
// sent to `sink` (when set) once when it appears, latched in *faulted until a reading without
// it, and returned as the reading's error ("device: fault").
Status latchFault(const std::string& device, const std::string& fault,
                  const std::function<void(const std::string&)>& sink, bool* faulted);

// CLOCK_REALTIME in seconds: the clock of the kernel's frame receive times (can_frame.h), so a
// reading stamped with it can be placed among the IMU's samples.
double unixTimeS();

}  // namespace imubench::drivers
