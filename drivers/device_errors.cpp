#include "drivers/device_errors.h"

#include <ctime>

#include "io/enum_names.h"

namespace imubench::drivers {

constexpr io::Named<DeviceState> kDeviceStateNames[] = {
    {DeviceState::kOffline, "offline"},
    {DeviceState::kReady, "ready"},
    {DeviceState::kRetrying, "retrying"},
    {DeviceState::kFault, "fault"},
};

const char* deviceStateName(DeviceState s) {
  return io::nameOf(kDeviceStateNames, s, "unknown");
}

Status latchFault(const std::string& device, const std::string& fault,
                  const std::function<void(const std::string&)>& sink, bool* faulted) {
  if (fault.empty()) {
    *faulted = false;
    return Status::Ok();
  }
  if (!*faulted && sink) sink(device + ": fault: " + fault);
  *faulted = true;
  return Status::Error(device + ": " + fault);
}

double unixTimeS() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace imubench::drivers
