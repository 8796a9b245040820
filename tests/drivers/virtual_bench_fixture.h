// Test helpers: device files from the source tree, a virtual world with its servers, and
// waiting on state with a generous deadline (never a fixed sleep as synchronisation).
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/device_file.h"
#include "drivers/modbus_device_models.h"
#include "drivers/modbus_server.h"
#include "drivers/virtual_table_scpi.h"
#include "drivers/virtual_world.h"

namespace imubench::drivers::testing {

inline std::string deviceDir() {
  return std::string(IMUBENCH_SOURCE_DIR) + "/drivers/devices";
}

inline TableDeviceSpec tableSpec(const std::string& name) {
  io::Diagnostics diag(deviceDir() + "/tables/" + name);
  auto s = loadTableDevice(diag.file(), diag);
  EXPECT_TRUE(s.has_value()) << diag.str();
  return s ? *s : TableDeviceSpec{};
}

inline ChamberDeviceSpec chamberSpec(const std::string& name) {
  io::Diagnostics diag(deviceDir() + "/chambers/" + name);
  auto s = loadChamberDevice(diag.file(), diag);
  EXPECT_TRUE(s.has_value()) << diag.str();
  return s ? *s : ChamberDeviceSpec{};
}

// Collects events (what a program would log) so tests can check they were reported.
class EventLog {
 public:
  EventSink sink() {
    return [this](const std::string& m) {
      std::lock_guard lock(mu_);
      events_.push_back(m);
    };
  }
  bool contains(const std::string& needle) const {
    std::lock_guard lock(mu_);
    for (const auto& e : events_) {
      if (e.find(needle) != std::string::npos) return true;
    }
    return false;
  }
  std::string all() const {
    std::lock_guard lock(mu_);
    std::string s;
    for (const auto& e : events_) s += "  " + e + "\n";
    return s;
  }

 private:
  mutable std::mutex mu_;
  std::vector<std::string> events_;
};

// Polls cond until it holds or the wall-clock deadline passes (generous: loaded CI machines).
inline bool waitUntil(const std::function<bool()>& cond, double deadline_s = 30.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(deadline_s);
  while (std::chrono::steady_clock::now() < end) {
    if (cond()) return true;
    std::this_thread::yield();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // poll period, not a wait
  }
  return cond();
}

// The time scale of the virtual world in tests: motions of seconds pass in tens of ms.
inline constexpr double kTestTimeScale = 20.0;

}  // namespace imubench::drivers::testing
