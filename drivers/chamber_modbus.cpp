#include "drivers/chamber_modbus.h"

#include <cmath>

namespace imubench::drivers {

std::unique_ptr<ChamberDriver> makeChamberDriver(const ChamberDeviceSpec& spec, EventSink sink) {
  return std::make_unique<ModbusChamber>(spec, std::move(sink));
}

ModbusChamber::ModbusChamber(ChamberDeviceSpec spec, EventSink sink)
    : spec_(std::move(spec)),
      sink_(sink),
      link_(spec_.name(), spec_.transport, spec_.registers.word_order, sink) {}

DeviceState ModbusChamber::state() const {
  return alarm_fault_ ? DeviceState::kFault : link_.state();
}

Status ModbusChamber::setSetpoint(double temp_c) {
  if (!std::isfinite(temp_c) || temp_c < spec_.temp_min_c || temp_c > spec_.temp_max_c) {
    return Status::Error(spec_.name() + ": setpoint " + std::to_string(temp_c) +
                         " degC is outside the chamber range [" + std::to_string(spec_.temp_min_c) +
                         ", " + std::to_string(spec_.temp_max_c) + "] degC");
  }
  return link_.write(spec_.registers.setpoint, "write setpoint", temp_c);
}

Status ModbusChamber::setRampRate(double degc_per_s) {
  if (!std::isfinite(degc_per_s) || degc_per_s < 0 || degc_per_s > spec_.max_ramp * (1 + 1e-9)) {
    return Status::Error(spec_.name() + ": ramp rate " + std::to_string(degc_per_s * 60.0) +
                         " degC/min is outside [0, " + std::to_string(spec_.max_ramp * 60.0) +
                         "] degC/min");
  }
  return link_.write(spec_.registers.ramp_rate, "write ramp rate", degc_per_s);
}

Status ModbusChamber::run(bool on) {
  return link_.writeCode(spec_.registers.run, on ? "run" : "stop",
                         on ? spec_.codes.run : spec_.codes.stop);
}

Status ModbusChamber::read(ChamberReading* out) {
  ChamberReading r;
  const auto& m = spec_.registers;
  if (Status s = link_.read(m.temperature, "read temperature", &r.temperature_c); !s.ok) return s;
  if (Status s = link_.read(m.setpoint, "read setpoint", &r.setpoint_c); !s.ok) return s;
  if (Status s = link_.read(m.ramp_rate, "read ramp rate", &r.ramp_rate); !s.ok) return s;
  uint32_t run = 0;
  if (Status s = link_.readBits(m.run, "read run state", &run); !s.ok) return s;
  r.running = static_cast<int>(run) == spec_.codes.run;
  if (Status s = link_.readBits(m.alarms, "read alarms", &r.alarms_raw); !s.ok) return s;
  const auto& b = spec_.alarm_bits;
  r.alarm_high = ((r.alarms_raw >> b.high) & 1u) != 0;
  r.alarm_low = ((r.alarms_raw >> b.low) & 1u) != 0;
  r.alarm_sensor = ((r.alarms_raw >> b.sensor) & 1u) != 0;
  *out = r;
  const std::string why = r.alarm_high     ? "high-temperature alarm"
                          : r.alarm_low    ? "low-temperature alarm"
                          : r.alarm_sensor ? "sensor-break alarm"
                                           : "";
  return latchFault(spec_.name(), why, sink_, &alarm_fault_);
}

}  // namespace imubench::drivers
