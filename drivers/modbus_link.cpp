#include "drivers/modbus_link.h"

#include <modbus/modbus.h>
#include <poll.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "drivers/modbus_codec.h"

namespace imubench::drivers {

namespace {

std::string errnoText(int err) {
  if (err == ETIMEDOUT) return "no reply within the timeout";
  return modbus_strerror(err);
}

std::string msText(double s) {
  return std::to_string(std::lround(s * 1000.0)) + " ms";
}

}  // namespace

ModbusLink::ModbusLink(std::string device_name, TransportSpec transport, WordOrder order,
                       EventSink sink)
    : name_(std::move(device_name)),
      tr_(std::move(transport)),
      order_(order),
      sink_(std::move(sink)) {}

ModbusLink::~ModbusLink() {
  close();
}

void ModbusLink::close() {
  if (ctx_) {
    if (connected_) modbus_close(ctx_);
    modbus_free(ctx_);
  }
  ctx_ = nullptr;
  connected_ = false;
}

Status ModbusLink::open(std::string* why) {
  close();
  if (tr_.kind == TransportKind::kModbusTcp) {
    ctx_ = modbus_new_tcp(tr_.host.c_str(), tr_.port);
  } else {
    ctx_ = modbus_new_rtu(tr_.device.c_str(), tr_.baud, tr_.parity, tr_.data_bits, tr_.stop_bits);
  }
  if (!ctx_) {
    *why = std::string("cannot create Modbus context: ") + modbus_strerror(errno);
    return Status::Error(*why);
  }
  modbus_set_slave(ctx_, tr_.unit_id);
  const double t = tr_.retry.timeout_s;
  const auto sec = static_cast<uint32_t>(t);
  const auto usec = static_cast<uint32_t>(std::lround((t - sec) * 1e6));
  modbus_set_response_timeout(ctx_, sec, usec);
  if (modbus_connect(ctx_) == -1) {
    *why = std::string("cannot connect: ") + modbus_strerror(errno);
    modbus_free(ctx_);
    ctx_ = nullptr;
    return Status::Error(*why);
  }
  connected_ = true;
  return Status::Ok();
}

Status ModbusLink::connect() {
  std::string why;
  const std::string where = tr_.kind == TransportKind::kModbusTcp
                                ? tr_.host + ":" + std::to_string(tr_.port)
                                : tr_.device;
  if (!open(&why).ok) {
    state_ = DeviceState::kOffline;
    const std::string m = name_ + ": " + transportKindName(tr_.kind) + " " + where + ": " + why;
    emit(m);
    return Status::Error(m);
  }
  state_ = DeviceState::kReady;
  return Status::Ok();
}

Status ModbusLink::transact(std::string_view what, const std::function<int(_modbus*)>& attempt,
                            bool retry) {
  const int attempts = retry && !single_attempt_ ? 1 + tr_.retry.retries : 1;
  std::string why;
  for (int k = 1; k <= attempts; ++k) {
    if (!connected_) {
      if (k > 1 && !tr_.retry.reconnect) break;
      if (!open(&why).ok) {
        state_ = DeviceState::kRetrying;
        emit(name_ + ": " + std::string(what) + ": attempt " + std::to_string(k) + "/" +
             std::to_string(attempts) + " failed: " + why);
        continue;
      }
    }
    errno = 0;
    if (attempt(ctx_) != -1) {
      if (state_ != DeviceState::kReady && k > 1) {
        emit(name_ + ": " + std::string(what) + ": succeeded on attempt " + std::to_string(k));
      }
      state_ = DeviceState::kReady;
      return Status::Ok();
    }
    const int err = errno;
    why = errnoText(err);
    if (err == ETIMEDOUT) why = "no reply within " + msText(tr_.retry.timeout_s);
    // A device exception is an answer, not a lost link: no retry.
    if (err > MODBUS_ENOBASE && err < MODBUS_ENOBASE + 12 && err != EMBBADCRC) {
      state_ = DeviceState::kFault;
      const std::string m = name_ + ": " + std::string(what) + ": device refused: " + why;
      emit(m);
      return Status::Error(m);
    }
    state_ = DeviceState::kRetrying;
    emit(name_ + ": " + std::string(what) + ": attempt " + std::to_string(k) + "/" +
         std::to_string(attempts) + " failed: " + why);
    // Drop the link so a late reply to this request cannot be taken for the next one's.
    if (tr_.kind == TransportKind::kModbusTcp) {
      close();
    } else {
      drainUntilQuiet();
    }
  }
  state_ = DeviceState::kFault;
  const std::string m = name_ + ": " + std::string(what) + ": fault after " +
                        std::to_string(attempts) + " attempts: " + why;
  emit(m);
  return Status::Error(m);
}

void ModbusLink::drainUntilQuiet() {
  // RTU has no transaction ids: wait until the line is quiet for one timeout (at most four)
  // and drop what came, so a late reply cannot answer the next request.
  const int fd = modbus_get_socket(ctx_);
  const int quiet_ms = static_cast<int>(tr_.retry.timeout_s * 1000);
  for (int k = 0; k < 4 && fd >= 0; ++k) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, quiet_ms) <= 0) break;
    modbus_flush(ctx_);
  }
  modbus_flush(ctx_);
}

Status ModbusLink::readRegisters(const RegisterField& f, std::string_view what, uint16_t regs[2]) {
  return transact(what, [&](_modbus* ctx) {
    return f.bank == RegisterBank::kInput
               ? modbus_read_input_registers(ctx, f.address, f.width(), regs)
               : modbus_read_registers(ctx, f.address, f.width(), regs);
  });
}

Status ModbusLink::read(const RegisterField& f, std::string_view what, double* si) {
  uint16_t regs[2] = {0, 0};
  Status s = readRegisters(f, what, regs);
  if (s.ok) *si = decodeRegister(f, order_, regs);
  return s;
}

Status ModbusLink::readBits(const RegisterField& f, std::string_view what, uint32_t* bits) {
  uint16_t regs[2] = {0, 0};
  Status s = readRegisters(f, what, regs);
  if (s.ok)
    *bits = f.width() == 1 ? regs[0] : static_cast<uint32_t>(decodeRegister(f, order_, regs));
  return s;
}

Status ModbusLink::write(const RegisterField& f, std::string_view what, double si) {
  uint16_t regs[2] = {0, 0};
  encodeRegister(f, order_, si, regs);
  return transact(what, [&](_modbus* ctx) {
    return f.width() == 1 ? modbus_write_register(ctx, f.address, regs[0])
                          : modbus_write_registers(ctx, f.address, 2, regs);
  });
}

Status ModbusLink::writeCode(const RegisterField& f, std::string_view what, int code, bool retry) {
  return transact(
      what,
      [&](_modbus* ctx) {
        return modbus_write_register(ctx, f.address, static_cast<uint16_t>(code));
      },
      retry);
}

}  // namespace imubench::drivers
