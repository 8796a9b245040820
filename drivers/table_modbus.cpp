#include "drivers/table_modbus.h"

#include <cmath>

namespace imubench::drivers {

ModbusTable::ModbusTable(TableDeviceSpec spec, EventSink sink)
    : spec_(std::move(spec)),
      sink_(sink),
      link_(spec_.name(), spec_.transport, spec_.registers.word_order, sink) {}

Status ModbusTable::connect() {
  return link_.connect();
}

DeviceState ModbusTable::state() const {
  if (status_fault_) return DeviceState::kFault;
  return link_.state();
}

std::string ModbusTable::what(std::string_view request, int axis) const {
  return std::string(request) + (axis >= 0 ? " (axis " + std::to_string(axis) + ")" : "");
}

Status ModbusTable::checkMotionAllowed() {
  uint32_t raw = 0;
  Status s = link_.readBits(spec_.registers.status, "read status", &raw);
  if (!s.ok) return s;
  return checkTableMotion(spec_, raw, sink_, &status_fault_);
}

Status ModbusTable::startMotion(int axis, AxisMode mode, RegisterField TableAxisRegisters::*demand,
                                std::string_view demand_what, double value,
                                std::string_view command_what, int code, bool retry) {
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  const auto& ax = spec_.registers.axes[axis];
  if (Status s = setMode(axis, mode); !s.ok) return s;
  if (Status s = link_.write(ax.*demand, what(demand_what, axis), value); !s.ok) return s;
  return link_.writeCode(ax.command, what(command_what, axis), code, retry);
}

Status ModbusTable::setMode(int axis, AxisMode mode) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  const int code = mode == AxisMode::kOff        ? spec_.codes.mode_off
                   : mode == AxisMode::kPosition ? spec_.codes.mode_position
                                                 : spec_.codes.mode_rate;
  return link_.writeCode(spec_.registers.axes[axis].mode, what("set mode", axis), code);
}

Status ModbusTable::setProfile(int axis, const MotionLimits& limits) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableProfile(spec_, limits); !s.ok) return s;
  const auto& ax = spec_.registers.axes[axis];
  if (Status s = link_.write(ax.rate_limit, what("write rate limit", axis), limits.rate); !s.ok) {
    return s;
  }
  return link_.write(ax.accel_limit, what("write acceleration limit", axis), limits.accel);
}

Status ModbusTable::moveTo(int axis, double angle) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableTarget(spec_, angle); !s.ok) return s;
  return startMotion(axis, AxisMode::kPosition, &TableAxisRegisters::position_demand,
                     "write position demand", angle, "command move", spec_.codes.cmd_move);
}

Status ModbusTable::rotateBy(int axis, double delta) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (!std::isfinite(delta)) return Status::Error(spec_.name() + ": rotation is not finite");
  // Not retried: a relative rotation whose command was lost may have started already.
  return startMotion(axis, AxisMode::kPosition, &TableAxisRegisters::rotate_by, "write rotation",
                     delta, "command rotate", spec_.codes.cmd_rotate, /*retry=*/false);
}

Status ModbusTable::setRate(int axis, double rate) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableRate(spec_, rate); !s.ok) return s;
  return startMotion(axis, AxisMode::kRate, &TableAxisRegisters::rate_demand, "write rate demand",
                     rate, "command move", spec_.codes.cmd_move);
}

Status ModbusTable::stop(int axis) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  return link_.writeCode(spec_.registers.axes[axis].command, what("command stop", axis),
                         spec_.codes.cmd_stop);
}

Status ModbusTable::emergencyStop() {
  return link_.writeCode(spec_.registers.control, "emergency stop", spec_.codes.ctl_estop);
}

Status ModbusTable::interlock(InterlockCommand c) {
  const int code = c == InterlockCommand::kClose  ? spec_.codes.ctl_interlock_close
                   : c == InterlockCommand::kOpen ? spec_.codes.ctl_interlock_open
                                                  : spec_.codes.ctl_interlock_reset;
  Status s = link_.writeCode(spec_.registers.control, "interlock command", code);
  if (s.ok && c != InterlockCommand::kOpen) status_fault_ = false;
  return s;
}

Status ModbusTable::read(TableReading* out) {
  if (spec_.watchdog.declared()) {
    heartbeat_ = (heartbeat_ + 1) % kHeartbeatModulo;
    if (Status s = link_.write(spec_.watchdog.heartbeat, "write heartbeat",
                               static_cast<double>(heartbeat_));
        !s.ok) {
      return s;
    }
  }
  TableReading r;
  uint32_t raw = 0;
  if (Status s = link_.readBits(spec_.registers.status, "read status", &raw); !s.ok) return s;
  const std::string fault = decodeTableStatus(spec_.bits, raw, &r);
  r.axes.resize(static_cast<size_t>(spec_.axisCount()));
  for (int i = 0; i < spec_.axisCount(); ++i) {
    const auto& ax = spec_.registers.axes[i];
    auto& a = r.axes[i];
    const double asked = unixTimeS();
    if (Status s = link_.read(ax.position, what("read position", i), &a.angle); !s.ok) return s;
    {
      const double replied = unixTimeS();
      a.read_unix_s = 0.5 * (asked + replied);
      a.round_trip_s = replied - asked;
    }
    if (Status s = link_.read(ax.rate, what("read rate", i), &a.rate); !s.ok) return s;
    uint32_t st = 0;
    if (Status s = link_.readBits(ax.status, what("read axis status", i), &st); !s.ok) return s;
    a.moving = ((st >> spec_.bits.axis_moving) & 1u) != 0;
    a.in_position = ((st >> spec_.bits.axis_in_position) & 1u) != 0;
  }
  *out = r;
  return latchFault(spec_.name(), fault, sink_, &status_fault_);
}

}  // namespace imubench::drivers
