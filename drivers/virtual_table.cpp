#include "drivers/virtual_table.h"

#include <algorithm>
#include <cmath>

#include "calib/model/motion_profile.h"
#include "nav/rotation.h"

namespace imubench::drivers {

namespace {
using calib::model::kRestRate;        // rad/s: below this an axis is at rest
constexpr double kInPosition = 1e-6;  // rad: position-mode target reached
double wrapPi(double a) {
  double w = std::remainder(a, 2.0 * kPi);
  if (w <= -kPi) w += 2.0 * kPi;
  return w;
}
}  // namespace

VirtualTable::VirtualTable(const TableDeviceSpec& spec, double t0)
    : spec_(spec), wd_timeout_(spec.watchdog.timeout_s) {
  motion_.kind = spec.kind;
  motion_.axes.resize(static_cast<size_t>(spec.axisCount()));
  axes_.resize(static_cast<size_t>(spec.axisCount()));
  for (auto& a : motion_.axes) a.append({t0, 0.0, 0.0, 0.0});
}

void VirtualTable::commit(double t) {
  checkWatchdog(t);
  for (size_t i = 0; i < axes_.size(); ++i) {
    auto& p = axes_[i].pending;
    size_t n = 0;
    while (n < p.size() && p[n].t0 <= t) motion_.axes[i].append(p[n++]);
    p.erase(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(n));
  }
  motion_.duration = std::max(motion_.duration, t);
}

calib::AxisState VirtualTable::stateAt(double t, int i) {
  commit(t);
  return motion_.axes[static_cast<size_t>(i)].at(t);
}

void VirtualTable::replan(double t, int i, std::vector<calib::AxisPhase> phases) {
  commit(t);
  auto& ax = axes_[static_cast<size_t>(i)];
  ax.pending.clear();
  // The first phase starts now: it goes straight into the executed motion.
  motion_.axes[static_cast<size_t>(i)].append(phases.front());
  ax.pending.assign(phases.begin() + 1, phases.end());
}

double VirtualTable::rateLimit(int i) const {
  const double r = axes_[static_cast<size_t>(i)].rate_limit;
  return r > 0.0 ? std::min(r, spec_.limits.max_rate) : spec_.limits.max_rate;
}

double VirtualTable::accelLimit(int i) const {
  const double a = axes_[static_cast<size_t>(i)].accel_limit;
  return a > 0.0 ? std::min(a, spec_.limits.max_accel) : spec_.limits.max_accel;
}

bool VirtualTable::setRateLimit(int i, double rate, std::string* why) {
  if (i < 0 || i >= spec_.axisCount() || !std::isfinite(rate) || !(rate > 0.0)) {
    *why = "rate limit must be positive";
    return false;
  }
  axes_[static_cast<size_t>(i)].rate_limit = rate;
  return true;
}

bool VirtualTable::setAccelLimit(int i, double accel, std::string* why) {
  if (i < 0 || i >= spec_.axisCount() || !std::isfinite(accel) || !(accel > 0.0)) {
    *why = "acceleration limit must be positive";
    return false;
  }
  axes_[static_cast<size_t>(i)].accel_limit = accel;
  return true;
}

// The table's profile (calib/model/motion_profile.h): a rate change at acceleration a.
void VirtualTable::planRate(double t, int i, double r, double a) {
  replan(t, i, calib::model::rateProfile(t, stateAt(t, i), r, a));
}

// The table's profile: from the current state to rest at x1 within the axis' limits.
void VirtualTable::planMove(double t, int i, double x1) {
  replan(t, i, calib::model::moveProfile(t, stateAt(t, i), x1, {rateLimit(i), accelLimit(i)}));
}

bool VirtualTable::motionAllowed(std::string* why) const {
  if (tripped_) {
    *why = "interlock tripped: " + trip_reason_;
    return false;
  }
  if (estop_) {
    *why = "emergency stop active (reset the interlock)";
    return false;
  }
  if (!interlock_closed_) {
    *why = "interlock open";
    return false;
  }
  return true;
}

bool VirtualTable::setMode(double t, int i, AxisMode mode, std::string* why) {
  if (i < 0 || i >= spec_.axisCount()) {
    *why = "no axis " + std::to_string(i);
    return false;
  }
  auto& ax = axes_[static_cast<size_t>(i)];
  if (ax.mode != mode) {
    planRate(t, i, 0.0, accelLimit(i));  // a mode change brakes the axis first
    ax.has_target = false;
  }
  ax.mode = mode;
  return true;
}

VirtualTable::Axis* VirtualTable::commandable(double t, int i, AxisMode mode, std::string* why) {
  commit(t);  // an expired watchdog has opened the interlock first
  if (!motionAllowed(why)) return nullptr;
  if (i < 0 || i >= spec_.axisCount()) {
    *why = "no axis " + std::to_string(i);
    return nullptr;
  }
  Axis& ax = axes_[static_cast<size_t>(i)];
  if (ax.mode != mode) {
    *why = mode == AxisMode::kRate ? "axis not in rate mode" : "axis not in position mode";
    return nullptr;
  }
  return &ax;
}

void VirtualTable::goTo(double t, int i, double x1) {
  Axis& ax = axes_[static_cast<size_t>(i)];
  ax.has_target = true;
  ax.target = x1;
  planMove(t, i, x1);
}

bool VirtualTable::moveTo(double t, int i, double angle, std::string* why) {
  if (commandable(t, i, AxisMode::kPosition, why) == nullptr) return false;
  const calib::AxisState s = stateAt(t, i);
  double x1 = angle;
  if (!spec_.limits.limited_travel) {
    x1 = s.angle + wrapPi(angle - s.angle);  // shortest way
  } else if (angle < spec_.limits.position_min || angle > spec_.limits.position_max) {
    *why = "target outside the travel range";
    return false;
  }
  goTo(t, i, x1);
  return true;
}

bool VirtualTable::rotateBy(double t, int i, double delta, std::string* why) {
  const Axis* ax = commandable(t, i, AxisMode::kPosition, why);
  if (ax == nullptr) return false;
  const double base = ax->has_target ? ax->target : stateAt(t, i).angle;
  const double x1 = base + delta;
  if (spec_.limits.limited_travel &&
      (x1 < spec_.limits.position_min || x1 > spec_.limits.position_max)) {
    *why = "rotation would leave the travel range";
    return false;
  }
  goTo(t, i, x1);
  return true;
}

bool VirtualTable::setRate(double t, int i, double rate, std::string* why) {
  if (commandable(t, i, AxisMode::kRate, why) == nullptr) return false;
  if (std::abs(rate) > spec_.limits.max_rate * (1 + 1e-9)) {
    *why = "rate above the limit";
    return false;
  }
  planRate(t, i, rate, accelLimit(i));
  return true;
}

void VirtualTable::stop(double t, int i) {
  if (i < 0 || i >= spec_.axisCount()) return;
  axes_[static_cast<size_t>(i)].has_target = false;
  planRate(t, i, 0.0, accelLimit(i));
}

// Emergency stop and the safety chain brake as hard as the device can, whatever the profile.
void VirtualTable::brakeAll(double t) {
  for (int i = 0; i < spec_.axisCount(); ++i) {
    axes_[static_cast<size_t>(i)].has_target = false;
    planRate(t, i, 0.0, spec_.limits.max_accel);
  }
}

void VirtualTable::emergencyStop(double t) {
  estop_ = true;
  brakeAll(t);
}

void VirtualTable::interlockClose(double t, std::string* why) {
  commit(t);
  if (tripped_) {
    *why = "interlock tripped: " + trip_reason_ + " (reset first)";
    return;
  }
  interlock_closed_ = true;
}

void VirtualTable::interlockOpen(double t) {
  interlock_closed_ = false;
  brakeAll(t);
}

void VirtualTable::interlockReset(double t) {
  commit(t);
  tripped_ = false;
  estop_ = false;
  trip_reason_.clear();
}

void VirtualTable::trip(double t, std::string reason) {
  tripped_ = true;
  trip_reason_ = std::move(reason);
  interlock_closed_ = false;
  brakeAll(t);
}

void VirtualTable::restart(double t) {
  brakeAll(t);
  for (Axis& a : axes_) a.mode = AxisMode::kOff;
  interlock_closed_ = false;
  tripped_ = false;
  estop_ = false;
  trip_reason_.clear();
}

void VirtualTable::heartbeat(double t, uint32_t value) {
  commit(t);  // a timeout that ran out before this heartbeat has fired
  if (wd_value_ == value) return;
  wd_value_ = value;
  ++wd_beats_;
  wd_armed_ = true;
  wd_last_t_ = t;
}

void VirtualTable::checkWatchdog(double t) {
  if (!wd_armed_ || t <= wd_last_t_ + wd_timeout_) return;
  const double at = wd_last_t_ + wd_timeout_;
  wd_armed_ = false;  // before braking: brakeAll commits at `at` and comes back here
  ++wd_expiries_;
  interlock_closed_ = false;
  brakeAll(at);
}

VirtualAxisStatus VirtualTable::axis(double t, int i) {
  const calib::AxisState s = stateAt(t, i);
  const auto& ax = axes_[static_cast<size_t>(i)];
  VirtualAxisStatus v;
  v.angle = s.angle;
  v.reported_angle = spec_.limits.limited_travel ? s.angle : wrapPi(s.angle);
  v.rate = s.rate;
  v.mode = ax.mode;
  v.moving = std::abs(s.rate) > kRestRate || std::abs(s.accel) > 0.0 || !ax.pending.empty();
  v.in_position = ax.mode == AxisMode::kPosition && ax.has_target && !v.moving &&
                  std::abs(s.angle - ax.target) < kInPosition;
  return v;
}

uint32_t VirtualTable::statusWord(double t) {
  commit(t);
  const auto& b = spec_.bits;
  uint32_t w = 0;
  if (interlock_closed_) w |= 1u << b.interlock_closed;
  if (tripped_) w |= 1u << b.interlock_tripped;
  if (estop_) w |= 1u << b.estop;
  return w;
}

uint32_t VirtualTable::axisStatusWord(double t, int i) {
  const VirtualAxisStatus s = axis(t, i);
  uint32_t w = 0;
  if (s.moving) w |= 1u << spec_.bits.axis_moving;
  if (s.in_position) w |= 1u << spec_.bits.axis_in_position;
  return w;
}

const calib::Motion& VirtualTable::motion(double t) {
  commit(t);
  return motion_;
}

}  // namespace imubench::drivers
