// Thermal chamber drivers behind one small interface: setpoint, ramp rate, run/stop, actual
// temperature, alarms. Implementation: Modbus TCP/RTU (chamber_modbus) with the device
// file's register map (a Watlow F4-style map and a generic float map ship with the project).
#pragma once

#include <cstdint>
#include <memory>

#include "drivers/device_errors.h"
#include "drivers/device_file.h"

namespace imubench::drivers {

struct ChamberReading {
  double temperature_c = 0.0;  // process value
  double setpoint_c = 0.0;
  double ramp_rate = 0.0;  // degC/s
  bool running = false;
  uint32_t alarms_raw = 0;
  bool alarm_high = false, alarm_low = false, alarm_sensor = false;
};

class ChamberDriver {
 public:
  virtual ~ChamberDriver() = default;
  virtual Status connect() = 0;
  virtual Status setSetpoint(double temp_c) = 0;
  virtual Status setRampRate(double degc_per_s) = 0;  // 0: step to the setpoint
  virtual Status run(bool on) = 0;
  // Fills the reading; an active alarm puts the driver in kFault and returns its reason.
  virtual Status read(ChamberReading* out) = 0;
  virtual DeviceState state() const = 0;
  virtual const ChamberDeviceSpec& spec() const = 0;
  // As TableDriver::setSingleAttempt: one attempt per request while on.
  virtual void setSingleAttempt(bool on) = 0;
};

std::unique_ptr<ChamberDriver> makeChamberDriver(const ChamberDeviceSpec& spec, EventSink sink);

}  // namespace imubench::drivers
