// One Modbus TCP or RTU connection (libmodbus) with the device file's retry policy: every
// request gets the reply timeout; a failed attempt is retried up to `retries` times
// (reconnecting first when the policy says so); when the attempts are used up the link is in
// kFault and the call returns an error naming the device, the request and why. The next call
// starts a fresh attempt cycle, so a device that comes back is picked up again.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "drivers/device_errors.h"
#include "drivers/device_file.h"

struct _modbus;

namespace imubench::drivers {

class ModbusLink {
 public:
  // device_name appears in every message; transport carries address, timeout and retries.
  ModbusLink(std::string device_name, TransportSpec transport, WordOrder order, EventSink sink);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  Status connect();
  void close();
  DeviceState state() const { return state_; }

  // Scaled field access (device file scaling and word order).
  Status read(const RegisterField& f, std::string_view what, double* si);
  Status readBits(const RegisterField& f, std::string_view what, uint32_t* bits);
  Status write(const RegisterField& f, std::string_view what, double si);
  // retry=false for commands that must not run twice (a relative rotation whose reply was
  // lost may have been executed): a failure then goes straight to kFault.
  Status writeCode(const RegisterField& f, std::string_view what, int code, bool retry = true);
  // On: every request gets one attempt, not the retry policy's chain (TableDriver::
  // setSingleAttempt: a caller polling a device that does not answer).
  void setSingleAttempt(bool on) { single_attempt_ = on; }

 private:
  // Reads the field's one or two registers from its bank (holding or input) into regs.
  Status readRegisters(const RegisterField& f, std::string_view what, uint16_t regs[2]);
  // Runs one request with the retry policy; `attempt` returns libmodbus' rc (-1: errno set).
  Status transact(std::string_view what, const std::function<int(_modbus*)>& attempt,
                  bool retry = true);
  Status open(std::string* why);
  void drainUntilQuiet();
  void emit(const std::string& m) const {
    if (sink_) sink_(m);
  }

  std::string name_;
  TransportSpec tr_;
  WordOrder order_;
  EventSink sink_;
  _modbus* ctx_ = nullptr;
  bool connected_ = false;
  bool single_attempt_ = false;
  DeviceState state_ = DeviceState::kOffline;
};

}  // namespace imubench::drivers
