#include "drivers/virtual_chamber.h"

#include <algorithm>
#include <cmath>

namespace imubench::drivers {

VirtualChamber::VirtualChamber(const ChamberDeviceSpec& spec, double ambient_c, double t0)
    : spec_(spec),
      ambient_c_(ambient_c),
      t_(t0),
      temp_c_(ambient_c),
      ramp_target_c_(ambient_c),
      setpoint_(ambient_c) {
  history_.push_back({t0, ambient_c});
}

void VirtualChamber::advance(double t) {
  if (t <= t_) return;
  const double tau = spec_.time_constant_s;
  // Sub-steps short against the time constant; the lag is integrated exactly per step with
  // the ramp target held at the step's midpoint value.
  const double max_step = std::min(1.0, tau / 20.0);
  while (t_ < t) {
    const double h = std::min(max_step, t - t_);
    const double goal = running_ ? setpoint_ : ambient_c_;
    double target_mid = goal;
    if (ramp_ > 0) {
      const double step = ramp_ * h;
      const double next = ramp_target_c_ + std::clamp(goal - ramp_target_c_, -step, step);
      target_mid = 0.5 * (ramp_target_c_ + next);
      ramp_target_c_ = next;
    } else {
      ramp_target_c_ = goal;
    }
    temp_c_ = target_mid + (temp_c_ - target_mid) * std::exp(-h / tau);
    t_ += h;
    if (t_ - history_.back().t >= kKnotSpacing) history_.push_back({t_, temp_c_});
  }
}

void VirtualChamber::setSetpoint(double t, double temp_c) {
  advance(t);
  setpoint_ = temp_c;
}

void VirtualChamber::setRampRate(double t, double degc_per_s) {
  advance(t);
  ramp_ = std::max(0.0, degc_per_s);
}

void VirtualChamber::run(double t, bool on) {
  advance(t);
  if (on && !running_) ramp_target_c_ = temp_c_;  // the ramp starts from where the air is
  running_ = on;
}

void VirtualChamber::setSensorBreak(double t, bool broken) {
  advance(t);
  sensor_break_ = broken;
}

double VirtualChamber::temperature(double t) {
  advance(t);
  return sensor_break_ ? spec_.temp_max_c + 50.0 : temp_c_;  // open thermocouple reads high
}

uint32_t VirtualChamber::alarmWord(double t) {
  advance(t);
  const auto& b = spec_.alarm_bits;
  uint32_t w = 0;
  if (sensor_break_) w |= 1u << b.sensor;
  if (!sensor_break_ && temp_c_ > spec_.temp_max_c + 2.0) w |= 1u << b.high;
  if (!sensor_break_ && temp_c_ < spec_.temp_min_c - 2.0) w |= 1u << b.low;
  return w;
}

const std::vector<calib::TemperatureKnot>& VirtualChamber::history(double t) {
  advance(t);
  return history_;
}

}  // namespace imubench::drivers
