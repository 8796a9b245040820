// Turntable over an SCPI-like ASCII command set on a serial line, in the style of common
// rate-table controllers: mode, demand position/rate, relative rotation, read position/rate,
// interlock close/open/reset, status byte. Command texts come from the device file.
#pragma once

#include "drivers/serial_port.h"
#include "drivers/table.h"

namespace imubench::drivers {

// Fills a command template ("{axis}", "{value}").
std::string formatCommand(const std::string& tmpl, int axis_number, double value);

class SerialTable final : public TableDriver {
 public:
  SerialTable(TableDeviceSpec spec, EventSink sink);
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
  void setSingleAttempt(bool on) override { single_attempt_ = on; }

 private:
  // Sends a command and, if `reply` is set, reads the answer line (queries), else the ack.
  Status exchange(const SerialCommand& c, int axis, double value, std::string_view what,
                  std::string* reply, bool retry = true);
  Status query(const SerialCommand& c, int axis, std::string_view what, double* number);
  Status checkMotionAllowed();
  void emit(const std::string& m) const {
    if (sink_) sink_(m);
  }

  TableDeviceSpec spec_;
  EventSink sink_;
  SerialPort port_;
  DeviceState state_ = DeviceState::kOffline;
  bool status_fault_ = false;
  bool single_attempt_ = false;
};

}  // namespace imubench::drivers
