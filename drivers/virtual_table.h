// The virtual turntable's controller physics, as a pure model driven by explicit times: every
// command at time t plans the table's motion profile (calib/model/motion_profile.h, the one
// the plan expander predicts with) from the axis' current state and the
// motion becomes calib::AxisPhase entries of a growing calib::Motion (so the simulator can
// run on exactly what the table did). Phases are kept pending until their start time has
// passed, so a new command can replace the rest of a plan.
//
// Controller behaviour modelled on common rate tables: modes off/position/rate; position mode
// takes the shortest way (a 180-degree reversal needs a rotation with explicit direction);
// motion needs a closed interlock; opening or tripping it brakes every axis to rest. The
// host watchdog of a device file that declares one (TableDeviceSpec::watchdog): once armed
// by a heartbeat, a heartbeat that has not changed for longer than the timeout brakes every
// axis to rest and opens the interlock, as a controller does when its host dies.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "calib/model/motion.h"
#include "drivers/device_file.h"
#include "drivers/table.h"

namespace imubench::drivers {

struct VirtualAxisStatus {
  double angle = 0.0;           // continuous (unwrapped) angle, rad
  double reported_angle = 0.0;  // what the controller reports: wrapped to (-pi, pi]
  double rate = 0.0;            // rad/s
  AxisMode mode = AxisMode::kOff;
  bool moving = false;
  bool in_position = false;
};

class VirtualTable {
 public:
  explicit VirtualTable(const TableDeviceSpec& spec, double t0 = 0.0);

  // Commands at time t (non-decreasing). false + *why when the controller refuses.
  bool setMode(double t, int axis, AxisMode mode, std::string* why);
  bool moveTo(double t, int axis, double angle, std::string* why);
  bool rotateBy(double t, int axis, double delta, std::string* why);
  bool setRate(double t, int axis, double rate, std::string* why);
  // The profile of the axis' next commands (moves, rotations, rate changes, braking): rate
  // and acceleration, used as min(commanded, device file's limits). Not positive: refused.
  bool setRateLimit(int axis, double rate, std::string* why);
  bool setAccelLimit(int axis, double accel, std::string* why);
  void stop(double t, int axis);
  void emergencyStop(double t);
  void interlockClose(double t, std::string* why);
  void interlockOpen(double t);
  void interlockReset(double t);
  // Fault injection: the safety chain opens by itself (door switch, over-speed...).
  void trip(double t, std::string reason);
  // Fault injection: the controller reboots (brown-out, watchdog). Every axis brakes to rest,
  // modes go off, the interlock comes up open and the trip/emergency-stop latches are gone;
  // the angles stay (absolute encoders). Motion needs the interlock closed again (re-arm).
  void restart(double t);
  // The host watchdog: the heartbeat register written with `value` at time t. A value that
  // differs from the last one arms the watchdog and restarts its timer (the same value again
  // is no sign of life). Armed and unchanged for longer than watchdogTimeout(): from the
  // instant the timeout ran out, every axis brakes to rest at the device's max_accel (as an
  // opened interlock or an emergency stop brakes) and the interlock opens (no trip, no
  // emergency stop latched: the host's re-arm closes it again); the watchdog disarms until
  // the next changed heartbeat. Judged at every call that takes a time, so a table nobody
  // talks to any more stops at the right instant, as read later.
  void heartbeat(double t, uint32_t value);
  // The timeout in this model's time: the device file's timeout (wall seconds at the
  // controller) times the time scale of a world that runs faster than the wall clock.
  void setWatchdogTimeout(double model_s) { wd_timeout_ = model_s; }
  double watchdogTimeout() const { return wd_timeout_; }
  bool watchdogArmed() const { return wd_armed_; }
  int watchdogExpiries() const { return wd_expiries_; }   // times the watchdog ran out
  std::uint64_t heartbeats() const { return wd_beats_; }  // changed heartbeats received

  VirtualAxisStatus axis(double t, int i);
  uint32_t statusWord(double t);  // global bits per spec().bits
  uint32_t axisStatusWord(double t, int i);
  bool interlockClosed() const { return interlock_closed_; }
  const std::string& tripReason() const { return trip_reason_; }
  // The motion executed up to time t (phases that started after t are not in it yet).
  const calib::Motion& motion(double t);
  // The chamber's temperature history, so the Motion the simulator reads carries it too.
  // The executed Motion's temperature: the chamber's knots (a history that only grows: the new
  // ones are appended) and, after them, the IMU's temperature `now`, so that a sample made at
  // any time up to now reads a temperature (and a rate) that exists. The previous call's `now`
  // knot is replaced.
  void syncTemperature(const std::vector<calib::TemperatureKnot>& knots,
                       calib::TemperatureKnot now) {
    std::vector<calib::TemperatureKnot>& m = motion_.temperature;
    if (has_now_knot_) m.pop_back();
    for (std::size_t i = m.size(); i < knots.size(); ++i) m.push_back(knots[i]);
    has_now_knot_ = m.empty() || now.t > m.back().t;
    if (has_now_knot_) m.push_back(now);
  }
  const TableDeviceSpec& spec() const { return spec_; }

 private:
  bool has_now_knot_ = false;  // motion_.temperature ends with syncTemperature's `now`
  struct Axis {
    AxisMode mode = AxisMode::kOff;
    std::vector<calib::AxisPhase> pending;  // planned, t0 > committed time
    bool has_target = false;
    double target = 0.0;       // continuous angle of the position target
    double rate_limit = 0.0;   // commanded profile, rad/s (0: the device's limit)
    double accel_limit = 0.0;  // rad/s^2 (0: the device's limit)
  };
  double rateLimit(int i) const;   // min(commanded, device)
  double accelLimit(int i) const;  // min(commanded, device)
  void commit(double t);
  calib::AxisState stateAt(double t, int i);
  void replan(double t, int i, std::vector<calib::AxisPhase> phases);
  // Rest-to-rest (from any current state) move to continuous angle x1, limited rate/accel.
  void planMove(double t, int i, double x1);
  // Change to a constant rate r with acceleration a.
  void planRate(double t, int i, double r, double a);
  bool motionAllowed(std::string* why) const;
  // Axis i when it may take a command of `mode` now (motion allowed, the axis in that mode);
  // nullptr and *why otherwise.
  Axis* commandable(double t, int i, AxisMode mode, std::string* why);
  // An armed watchdog whose timeout ran out before t fires at that instant.
  void checkWatchdog(double t);
  // Position target x1 (continuous angle) set and the move there planned.
  void goTo(double t, int i, double x1);
  void brakeAll(double t);

  TableDeviceSpec spec_;
  calib::Motion motion_;
  std::vector<Axis> axes_;
  bool interlock_closed_ = false;
  bool tripped_ = false;
  bool estop_ = false;
  std::string trip_reason_;
  // Host watchdog.
  bool wd_armed_ = false;
  double wd_last_t_ = 0.0;  // when the heartbeat last changed
  std::optional<uint32_t> wd_value_;
  double wd_timeout_ = 0.0;
  int wd_expiries_ = 0;
  std::uint64_t wd_beats_ = 0;
};

}  // namespace imubench::drivers
