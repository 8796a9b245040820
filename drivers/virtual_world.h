// One simulated bench: a virtual clock with a time scale, the virtual table and the virtual
// chamber, behind one mutex so several protocol servers (threads) can serve them at once.
// The world also records what happened as a calib::Motion (table phases + temperature knots)
// for the simulator.
#pragma once

#include <chrono>
#include <mutex>
#include <utility>

#include "calib/model/motion.h"
#include "drivers/virtual_chamber.h"
#include "drivers/virtual_table.h"

namespace imubench::drivers {

// Simulated seconds since start = time_scale x wall seconds (steady clock).
class VirtualClock {
 public:
  explicit VirtualClock(double time_scale = 1.0)
      : scale_(time_scale), start_(std::chrono::steady_clock::now()) {}
  double now() const {
    return scale_ *
           std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double scale() const { return scale_; }

 private:
  double scale_;
  std::chrono::steady_clock::time_point start_;
};

class VirtualWorld {
 public:
  // imu_tau_s: the IMU's thermal lag behind the chamber air (VirtualChamber). The table's
  // host watchdog times the host's heartbeats on the wall clock, as a controller does: its
  // timeout in simulated time is the device file's times the time scale.
  VirtualWorld(const TableDeviceSpec& table, const ChamberDeviceSpec& chamber, double time_scale,
               double ambient_c = 20.0, double imu_tau_s = 0.0)
      : clock_(time_scale), table_(table, 0.0), chamber_(chamber, ambient_c, 0.0, imu_tau_s) {
    table_.setWatchdogTimeout(table.watchdog.timeout_s * time_scale);
  }

  double now() const { return clock_.now(); }
  const VirtualClock& clock() const { return clock_; }

  // Runs f(table, t) under the world's lock at the current simulated time.
  template <class F>
  auto withTable(F&& f) {
    std::lock_guard lock(mu_);
    return f(table_, clock_.now());
  }
  template <class F>
  auto withChamber(F&& f) {
    std::lock_guard lock(mu_);
    return f(chamber_, clock_.now());
  }
  // Runs f(motion, t) under the lock with the Motion the table executed up to now (chamber
  // temperatures included). The reference stays valid for the world's lifetime and only grows
  // (phases starting at or after the current time), which is what calib::ImuSimulator needs;
  // read it only inside withMotion.
  template <class F>
  auto withMotion(F&& f) {
    std::lock_guard lock(mu_);
    const double t = clock_.now();
    table_.syncTemperature(chamber_.history(t), {t, chamber_.imuTemperature(t)});
    return f(table_.motion(t), t);
  }
  // Everything executed so far as one Motion (copy).
  calib::Motion motionSnapshot() {
    std::lock_guard lock(mu_);
    const double t = clock_.now();
    calib::Motion m = table_.motion(t);
    m.temperature = chamber_.history(t);
    if (m.temperature.empty() || t > m.temperature.back().t) {
      m.temperature.push_back({t, chamber_.imuTemperature(t)});
    }
    m.duration = t;
    return m;
  }

 private:
  std::mutex mu_;
  VirtualClock clock_;
  VirtualTable table_;
  VirtualChamber chamber_;
};

}  // namespace imubench::drivers
