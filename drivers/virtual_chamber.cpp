#include "drivers/virtual_chamber.h"

#include <algorithm>

namespace imubench::drivers {

VirtualChamber::VirtualChamber(const ChamberDeviceSpec& spec, double ambient_c, double t0,
                               double imu_tau_s)
    : spec_(spec),
      ambient_c_(ambient_c),
      t_(t0),
      lag_{spec.time_constant_s, imu_tau_s},
      state_(calib::model::thermalAtRest(ambient_c)),
      setpoint_(ambient_c) {
  history_.push_back({t0, ambient_c});
}

// The chamber model (calib/model/thermal_lag.h) run to t, exactly, in steps that end on the
// history's knot times.
void VirtualChamber::advance(double t) {
  const double goal = running_ ? setpoint_ : ambient_c_;
  while (t_ < t) {
    const double next_knot = history_.back().t + calib::model::kThermalKnotSpacing;
    const double t1 = std::min(t, next_knot);
    state_ = calib::model::advanceThermal(state_, goal, ramp_, lag_, t1 - t_);
    t_ = t1;
    if (t_ >= next_knot) history_.push_back({t_, state_.sensor_c});
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
  if (on && !running_) state_.program_c = state_.air_c;  // the ramp starts from the air
  running_ = on;
}

void VirtualChamber::setSensorBreak(double t, bool broken) {
  advance(t);
  sensor_break_ = broken;
}

double VirtualChamber::temperature(double t) {
  advance(t);
  return sensor_break_ ? spec_.temp_max_c + 50.0 : state_.air_c;  // open thermocouple reads high
}

double VirtualChamber::imuTemperature(double t) {
  advance(t);
  return state_.sensor_c;
}

uint32_t VirtualChamber::alarmWord(double t) {
  advance(t);
  const auto& b = spec_.alarm_bits;
  uint32_t w = 0;
  if (sensor_break_) w |= 1u << b.sensor;
  if (!sensor_break_ && state_.air_c > spec_.temp_max_c + 2.0) w |= 1u << b.high;
  if (!sensor_break_ && state_.air_c < spec_.temp_min_c - 2.0) w |= 1u << b.low;
  return w;
}

const std::vector<calib::TemperatureKnot>& VirtualChamber::history(double t) {
  advance(t);
  return history_;
}

}  // namespace imubench::drivers
