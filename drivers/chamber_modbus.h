// Thermal chamber over Modbus TCP or RTU (register map from the device file).
#pragma once

#include "drivers/chamber.h"
#include "drivers/modbus_link.h"

namespace imubench::drivers {

class ModbusChamber final : public ChamberDriver {
 public:
  ModbusChamber(ChamberDeviceSpec spec, EventSink sink);
  Status connect() override { return link_.connect(); }
  Status setSetpoint(double temp_c) override;
  Status setRampRate(double degc_per_s) override;
  Status run(bool on) override;
  Status read(ChamberReading* out) override;
  DeviceState state() const override;
  const ChamberDeviceSpec& spec() const override { return spec_; }
  void setSingleAttempt(bool on) override { link_.setSingleAttempt(on); }

 private:
  ChamberDeviceSpec spec_;
  EventSink sink_;
  ModbusLink link_;
  bool alarm_fault_ = false;
};

}  // namespace imubench::drivers
