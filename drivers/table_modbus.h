// Turntable over Modbus TCP or RTU: the device file's register map, scaling and word order.
#pragma once

#include <cstdint>

#include "drivers/modbus_link.h"
#include "drivers/table.h"

namespace imubench::drivers {

class ModbusTable final : public TableDriver {
 public:
  ModbusTable(TableDeviceSpec spec, EventSink sink);
  Status connect() override;
  Status setMode(int axis, AxisMode mode) override;
  Status setProfile(int axis, const MotionLimits& limits) override;
  Status moveTo(int axis, double angle) override;
  Status rotateBy(int axis, double delta) override;
  Status setRate(int axis, double rate) override;
  Status stop(int axis) override;
  Status emergencyStop() override;
  Status interlock(InterlockCommand c) override;
  Status read(TableReading* out) override;
  DeviceState state() const override;
  const TableDeviceSpec& spec() const override { return spec_; }
  void setSingleAttempt(bool on) override { link_.setSingleAttempt(on); }

 private:
  // Motion needs a closed, untripped interlock: checked on the controller first so a refusal
  // names the reason instead of a silently ignored command.
  Status checkMotionAllowed();
  // A motion command on an axis whose arguments are checked: motion allowed, the axis' mode,
  // `value` to its `demand` register, then `code` to its command register.
  Status startMotion(int axis, AxisMode mode, RegisterField TableAxisRegisters::*demand,
                     std::string_view demand_what, double value, std::string_view command_what,
                     int code, bool retry = true);
  std::string what(std::string_view request, int axis) const;

  TableDeviceSpec spec_;
  EventSink sink_;
  ModbusLink link_;
  bool status_fault_ = false;
  // The host watchdog's heartbeat: one up per read, within every integer register type.
  static constexpr std::uint32_t kHeartbeatModulo = 32768;
  std::uint32_t heartbeat_ = 0;
};

}  // namespace imubench::drivers
