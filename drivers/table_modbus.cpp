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
  TableReading r;
  const std::string fault = decodeTableStatus(spec_.bits, raw, &r);
  if (!fault.empty()) {
    status_fault_ = true;
    const std::string m = spec_.name() + ": motion refused: " + fault;
    if (sink_) sink_(m);
    return Status::Error(m);
  }
  if (!r.interlock_closed) {
    return Status::Error(spec_.name() + ": motion refused: interlock open (close it first)");
  }
  return Status::Ok();
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
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  const auto& ax = spec_.registers.axes[axis];
  if (Status s = setMode(axis, AxisMode::kPosition); !s.ok) return s;
  if (Status s = link_.write(ax.position_demand, what("write position demand", axis), angle); !s.ok)
    return s;
  return link_.writeCode(ax.command, what("command move", axis), spec_.codes.cmd_move);
}

Status ModbusTable::rotateBy(int axis, double delta) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (!std::isfinite(delta)) return Status::Error(spec_.name() + ": rotation is not finite");
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  const auto& ax = spec_.registers.axes[axis];
  if (Status s = setMode(axis, AxisMode::kPosition); !s.ok) return s;
  if (Status s = link_.write(ax.rotate_by, what("write rotation", axis), delta); !s.ok) return s;
  return link_.writeCode(ax.command, what("command rotate", axis), spec_.codes.cmd_rotate,
                         /*retry=*/false);
}

Status ModbusTable::setRate(int axis, double rate) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableRate(spec_, rate); !s.ok) return s;
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  const auto& ax = spec_.registers.axes[axis];
  if (Status s = setMode(axis, AxisMode::kRate); !s.ok) return s;
  if (Status s = link_.write(ax.rate_demand, what("write rate demand", axis), rate); !s.ok)
    return s;
  return link_.writeCode(ax.command, what("command move", axis), spec_.codes.cmd_move);
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
    a.read_unix_s = 0.5 * (asked + unixTimeS());
    if (Status s = link_.read(ax.rate, what("read rate", i), &a.rate); !s.ok) return s;
    uint32_t st = 0;
    if (Status s = link_.readBits(ax.status, what("read axis status", i), &st); !s.ok) return s;
    a.moving = ((st >> spec_.bits.axis_moving) & 1u) != 0;
    a.in_position = ((st >> spec_.bits.axis_in_position) & 1u) != 0;
  }
  *out = r;
  if (!fault.empty()) {
    if (!status_fault_ && sink_) sink_(spec_.name() + ": fault: " + fault);
    status_fault_ = true;
    return Status::Error(spec_.name() + ": " + fault);
  }
  status_fault_ = false;
  return Status::Ok();
}

}  // namespace imubench::drivers
