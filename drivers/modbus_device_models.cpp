#include "drivers/modbus_device_models.h"

#include <modbus/modbus.h>

#include <algorithm>
#include <initializer_list>

#include "drivers/modbus_codec.h"

namespace imubench::drivers {

namespace {

uint16_t* bankOf(modbus_mapping_t* m, const RegisterField& f) {
  return f.bank == RegisterBank::kHolding ? m->tab_registers : m->tab_input_registers;
}

void put(modbus_mapping_t* m, const RegisterField& f, WordOrder o, double si) {
  if (f.present) encodeRegister(f, o, si, bankOf(m, f) + f.address);
}
void putBits(modbus_mapping_t* m, const RegisterField& f, uint32_t bits) {
  if (!f.present) return;
  uint16_t* r = bankOf(m, f) + f.address;
  if (f.width() == 1) {
    r[0] = static_cast<uint16_t>(bits);
  } else {
    encodeRegister(f, WordOrder::kHighFirst, static_cast<double>(bits) * f.lsb, r);
  }
}
double get(modbus_mapping_t* m, const RegisterField& f, WordOrder o) {
  return decodeRegister(f, o, bankOf(m, f) + f.address);
}
int code(modbus_mapping_t* m, const RegisterField& f) {
  return bankOf(m, f)[f.address];
}

bool hit(const RegisterField& f, int address, int count) {
  return f.present && f.bank == RegisterBank::kHolding && f.address < address + count &&
         address < f.address + f.width();
}

void grow(const RegisterField& f, int* holding, int* input) {
  if (!f.present) return;
  int& n = f.bank == RegisterBank::kHolding ? *holding : *input;
  n = std::max(n, f.address + f.width());
}

}  // namespace

VirtualTableRegisters::VirtualTableRegisters(VirtualWorld& world, const TableDeviceSpec& spec,
                                             EventSink sink)
    : VirtualRegisters(world, spec, std::move(sink)) {
  const auto& r = spec_.registers;
  grow(r.status, &holding_, &input_);
  grow(r.control, &holding_, &input_);
  grow(spec_.watchdog.heartbeat, &holding_, &input_);
  for (const auto& a : r.axes) {
    for (const RegisterField* f :
         {&a.mode, &a.position_demand, &a.rate_demand, &a.rotate_by, &a.command, &a.position,
          &a.rate, &a.status, &a.rate_limit, &a.accel_limit}) {
      grow(*f, &holding_, &input_);
    }
  }
}

void VirtualTableRegisters::reportWatchdog(const VirtualTable& table) {
  if (table.watchdogExpiries() == watchdog_reported_) return;
  watchdog_reported_ = table.watchdogExpiries();
  if (sink_) {
    sink_("virtual table: host watchdog: no heartbeat for more than " +
          std::to_string(spec_.watchdog.timeout_s) +
          " s: every axis braked to rest, interlock opened (re-arm to go on)");
  }
}

void VirtualTableRegisters::refresh(modbus_mapping_t* m) {
  const auto& r = spec_.registers;
  world_.withTable([&](VirtualTable& table, double t) {
    putBits(m, r.status, table.statusWord(t));
    reportWatchdog(table);
    for (int i = 0; i < static_cast<int>(r.axes.size()); ++i) {
      const auto& a = r.axes[static_cast<size_t>(i)];
      const VirtualAxisStatus s = table.axis(t, i);
      put(m, a.position, r.word_order, s.reported_angle);
      put(m, a.rate, r.word_order, s.rate);
      putBits(m, a.status, table.axisStatusWord(t, i));
    }
    return 0;
  });
}

void VirtualTableRegisters::written(modbus_mapping_t* m, int address, int count) {
  const auto& r = spec_.registers;
  const auto& c = spec_.codes;
  std::string why;
  auto refuse = [&](const std::string& what) {
    if (sink_) sink_("virtual table: " + what + " refused: " + why);
    why.clear();
  };
  world_.withTable([&](VirtualTable& table, double t) {
    const RegisterField& hb = spec_.watchdog.heartbeat;
    if (hit(hb, address, count)) {
      table.heartbeat(t, static_cast<uint32_t>(static_cast<int64_t>(get(m, hb, r.word_order))));
      reportWatchdog(table);
    }
    if (hit(r.control, address, count)) {
      const int k = code(m, r.control);
      if (k == c.ctl_estop) {
        table.emergencyStop(t);
      } else if (k == c.ctl_interlock_close) {
        table.interlockClose(t, &why);
        if (!why.empty()) refuse("interlock close");
      } else if (k == c.ctl_interlock_open) {
        table.interlockOpen(t);
      } else if (k == c.ctl_interlock_reset) {
        table.interlockReset(t);
      } else if (sink_) {
        sink_("virtual table: unknown control code " + std::to_string(k));
      }
    }
    for (int i = 0; i < static_cast<int>(r.axes.size()); ++i) {
      const auto& a = r.axes[static_cast<size_t>(i)];
      if (hit(a.mode, address, count)) {
        const int k = code(m, a.mode);
        const AxisMode mode = k == c.mode_position ? AxisMode::kPosition
                              : k == c.mode_rate   ? AxisMode::kRate
                                                   : AxisMode::kOff;
        if (!table.setMode(t, i, mode, &why)) refuse("mode");
      }
      // The profile first: a client writing it and the command in one request means both.
      if (hit(a.rate_limit, address, count) &&
          !table.setRateLimit(i, get(m, a.rate_limit, r.word_order), &why)) {
        refuse("rate limit");
      }
      if (hit(a.accel_limit, address, count) &&
          !table.setAccelLimit(i, get(m, a.accel_limit, r.word_order), &why)) {
        refuse("acceleration limit");
      }
      if (hit(a.command, address, count)) {
        const int k = code(m, a.command);
        const std::string axis = " (axis " + std::to_string(i) + ")";
        if (k == c.cmd_move) {
          const bool rate_mode = table.axis(t, i).mode == AxisMode::kRate;
          const bool ok = rate_mode
                              ? table.setRate(t, i, get(m, a.rate_demand, r.word_order), &why)
                              : table.moveTo(t, i, get(m, a.position_demand, r.word_order), &why);
          if (!ok) refuse("move" + axis);
        } else if (k == c.cmd_rotate) {
          if (!table.rotateBy(t, i, get(m, a.rotate_by, r.word_order), &why)) {
            refuse("rotate" + axis);
          }
        } else if (k == c.cmd_stop) {
          table.stop(t, i);
        } else if (sink_) {
          sink_("virtual table: unknown command code " + std::to_string(k) + axis);
        }
      }
    }
    return 0;
  });
}

VirtualChamberRegisters::VirtualChamberRegisters(VirtualWorld& world, const ChamberDeviceSpec& spec,
                                                 EventSink sink)
    : VirtualRegisters(world, spec, std::move(sink)) {
  const auto& r = spec_.registers;
  for (const RegisterField* f : {&r.setpoint, &r.temperature, &r.ramp_rate, &r.run, &r.alarms}) {
    grow(*f, &holding_, &input_);
  }
}

void VirtualChamberRegisters::refresh(modbus_mapping_t* m) {
  const auto& r = spec_.registers;
  world_.withChamber([&](VirtualChamber& ch, double t) {
    put(m, r.temperature, r.word_order, ch.temperature(t));
    put(m, r.setpoint, r.word_order, ch.setpoint());
    put(m, r.ramp_rate, r.word_order, ch.rampRate());
    putBits(m, r.run, static_cast<uint32_t>(ch.running() ? spec_.codes.run : spec_.codes.stop));
    putBits(m, r.alarms, ch.alarmWord(t));
    return 0;
  });
}

void VirtualChamberRegisters::written(modbus_mapping_t* m, int address, int count) {
  const auto& r = spec_.registers;
  world_.withChamber([&](VirtualChamber& ch, double t) {
    if (hit(r.setpoint, address, count)) ch.setSetpoint(t, get(m, r.setpoint, r.word_order));
    if (hit(r.ramp_rate, address, count)) ch.setRampRate(t, get(m, r.ramp_rate, r.word_order));
    if (hit(r.run, address, count)) {
      const int k = code(m, r.run);
      if (k == spec_.codes.run || k == spec_.codes.stop) {
        ch.run(t, k == spec_.codes.run);
      } else if (sink_) {
        sink_("virtual chamber: unknown run code " + std::to_string(k));
      }
    }
    return 0;
  });
}

}  // namespace imubench::drivers
