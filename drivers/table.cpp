#include "drivers/table.h"

#include <cmath>

#include "io/enum_names.h"
#include "nav/rotation.h"

namespace imubench::drivers {

constexpr io::Named<AxisMode> kAxisModeNames[] = {
    {AxisMode::kOff, "off"},
    {AxisMode::kPosition, "position"},
    {AxisMode::kRate, "rate"},
};

const char* axisModeName(AxisMode m) {
  return io::nameOf(kAxisModeNames, m, "?");
}

Status checkTableMotion(const TableDeviceSpec& spec, uint32_t raw, const EventSink& sink,
                        bool* status_fault) {
  TableReading r;
  const std::string fault = decodeTableStatus(spec.bits, raw, &r);
  if (!fault.empty()) {
    *status_fault = true;
    const std::string m = spec.name() + ": motion refused: " + fault;
    if (sink) sink(m);
    return Status::Error(m);
  }
  if (!r.interlock_closed) {
    return Status::Error(spec.name() + ": motion refused: interlock open (close it first)");
  }
  return Status::Ok();
}

Status checkTableAxis(const TableDeviceSpec& spec, int axis) {
  if (axis < 0 || axis >= spec.axisCount()) {
    return Status::Error(spec.name() + ": no axis " + std::to_string(axis) + " (table has " +
                         std::to_string(spec.axisCount()) + ")");
  }
  return Status::Ok();
}

Status checkTableRate(const TableDeviceSpec& spec, double rate) {
  if (!std::isfinite(rate) || std::abs(rate) > spec.limits.max_rate * (1.0 + 1e-9)) {
    return Status::Error(spec.name() + ": rate " + std::to_string(rate * kRadToDeg) +
                         " deg/s exceeds the device limit " +
                         std::to_string(spec.limits.max_rate * kRadToDeg) + " deg/s");
  }
  return Status::Ok();
}

Status checkTableTarget(const TableDeviceSpec& spec, double angle) {
  if (!std::isfinite(angle)) return Status::Error(spec.name() + ": target angle is not finite");
  if (spec.limits.limited_travel &&
      (angle < spec.limits.position_min || angle > spec.limits.position_max)) {
    return Status::Error(spec.name() + ": target " + std::to_string(angle * kRadToDeg) +
                         " deg is outside the travel range");
  }
  return Status::Ok();
}

Status checkTableProfile(const TableDeviceSpec& spec, const MotionLimits& limits) {
  if (!spec.profileSettable()) {
    return Status::Error(spec.name() + ": the device file gives no way to set the rate and " +
                         "acceleration of a motion (rate_limit/accel_limit registers or " +
                         "set_rate_limit/set_accel_limit commands): the controller would move " +
                         "at its own fixed profile, not the plan's");
  }
  if (!(std::isfinite(limits.rate) && limits.rate > 0.0) ||
      !(std::isfinite(limits.accel) && limits.accel > 0.0)) {
    return Status::Error(spec.name() + ": a motion profile needs a positive rate and " +
                         "acceleration");
  }
  if (limits.rate > spec.limits.max_rate * (1.0 + 1e-9) ||
      limits.accel > spec.limits.max_accel * (1.0 + 1e-9)) {
    return Status::Error(spec.name() + ": profile " + std::to_string(limits.rate * kRadToDeg) +
                         " deg/s, " + std::to_string(limits.accel * kRadToDeg) +
                         " deg/s^2 exceeds the limits " +
                         std::to_string(spec.limits.max_rate * kRadToDeg) + " deg/s, " +
                         std::to_string(spec.limits.max_accel * kRadToDeg) + " deg/s^2");
  }
  return Status::Ok();
}

std::string decodeTableStatus(const TableStatusBits& bits, uint32_t raw, TableReading* r) {
  auto bit = [raw](int b) { return ((raw >> b) & 1u) != 0; };
  r->status_raw = raw;
  r->interlock_closed = bit(bits.interlock_closed);
  r->interlock_tripped = bit(bits.interlock_tripped);
  r->estop = bit(bits.estop);
  r->fault = bit(bits.fault);
  if (r->interlock_tripped) return "interlock tripped (table safety chain opened)";
  if (r->estop) return "emergency stop active";
  if (r->fault) return "controller reports a fault";
  return {};
}

}  // namespace imubench::drivers
