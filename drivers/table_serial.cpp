#include "drivers/table_serial.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace imubench::drivers {

std::string formatCommand(const std::string& tmpl, int axis_number, double value) {
  std::string out = tmpl;
  if (auto p = out.find("{axis}"); p != std::string::npos) {
    out.replace(p, 6, std::to_string(axis_number));
  }
  if (auto p = out.find("{value}"); p != std::string::npos) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", value);
    out.replace(p, 7, buf);
  }
  return out;
}

SerialTable::SerialTable(TableDeviceSpec spec, EventSink sink)
    : spec_(std::move(spec)), sink_(std::move(sink)) {}

DeviceState SerialTable::state() const {
  return status_fault_ ? DeviceState::kFault : state_;
}

Status SerialTable::connect() {
  Status s = port_.open(spec_.transport);
  if (!s.ok) {
    state_ = DeviceState::kOffline;
    const std::string m = spec_.name() + ": serial: " + s.message;
    emit(m);
    return Status::Error(m);
  }
  state_ = DeviceState::kReady;
  return Status::Ok();
}

Status SerialTable::exchange(const SerialCommand& c, int axis, double value, std::string_view what,
                             std::string* reply, bool retry) {
  const std::string text = formatCommand(c.text, axis + spec_.commands.axis_base, value);
  const double timeout = c.timeout_s > 0 ? c.timeout_s : spec_.transport.retry.timeout_s;
  const int attempts = retry && !single_attempt_ ? 1 + spec_.transport.retry.retries : 1;
  const bool want_line = reply != nullptr || !spec_.commands.ack.empty();
  std::string why;
  for (int k = 1; k <= attempts; ++k) {
    if (!port_.isOpen()) {
      if (k > 1 && !spec_.transport.retry.reconnect) break;
      if (Status o = port_.open(spec_.transport); !o.ok) {
        why = o.message;
        state_ = DeviceState::kRetrying;
        emit(spec_.name() + ": " + std::string(what) + ": attempt " + std::to_string(k) + "/" +
             std::to_string(attempts) + " failed: " + why);
        continue;
      }
    }
    Status s = port_.writeLine(text);
    std::string line;
    if (s.ok && want_line) s = port_.readLine(timeout, &line);
    if (s.ok) {
      const auto& err = spec_.commands.error_prefix;
      if (!err.empty() && line.rfind(err, 0) == 0) {
        state_ = DeviceState::kFault;
        const std::string m = spec_.name() + ": " + std::string(what) + " (\"" + text +
                              "\"): device refused: " + line;
        emit(m);
        return Status::Error(m);
      }
      if (!reply && line != spec_.commands.ack) {
        s = Status::Error("unexpected reply \"" + line + "\" (expected \"" + spec_.commands.ack +
                          "\")");
      } else {
        if (reply) *reply = line;
        state_ = DeviceState::kReady;
        return Status::Ok();
      }
    }
    why = s.message;
    state_ = DeviceState::kRetrying;
    emit(spec_.name() + ": " + std::string(what) + " (\"" + text + "\"): attempt " +
         std::to_string(k) + "/" + std::to_string(attempts) + " failed: " + why);
    if (spec_.transport.retry.reconnect && why.find("timeout") == std::string::npos) {
      port_.close();  // a line error: reopen before the next attempt
    } else {
      port_.drainUntilQuiet(timeout, 4 * timeout);
    }
  }
  state_ = DeviceState::kFault;
  const std::string m = spec_.name() + ": " + std::string(what) + " (\"" + text +
                        "\"): fault after " + std::to_string(attempts) + " attempt" +
                        (attempts > 1 ? "s" : "") + ": " + why;
  emit(m);
  return Status::Error(m);
}

Status SerialTable::query(const SerialCommand& c, int axis, std::string_view what, double* number) {
  std::string line;
  if (Status s = exchange(c, axis, 0.0, what, &line); !s.ok) return s;
  size_t b = 0;
  while (b < line.size() && (line[b] == ' ' || line[b] == '+')) ++b;
  double v = 0.0;
  auto [p, ec] = std::from_chars(line.data() + b, line.data() + line.size(), v);
  if (ec != std::errc() || !std::isfinite(v)) {
    state_ = DeviceState::kFault;
    const std::string m =
        spec_.name() + ": " + std::string(what) + ": reply \"" + line + "\" is not a number";
    emit(m);
    return Status::Error(m);
  }
  *number = v;
  return Status::Ok();
}

Status SerialTable::checkMotionAllowed() {
  double raw = 0;
  if (Status s = query(spec_.commands.read_status, -1, "read status", &raw); !s.ok) return s;
  return checkTableMotion(spec_, static_cast<uint32_t>(raw), sink_, &status_fault_);
}

Status SerialTable::setMode(int axis, AxisMode mode) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  const auto& c = spec_.commands;
  const SerialCommand& cmd = mode == AxisMode::kOff        ? c.mode_off
                             : mode == AxisMode::kPosition ? c.mode_position
                                                           : c.mode_rate;
  return exchange(cmd, axis, 0.0, "set mode", nullptr);
}

Status SerialTable::setProfile(int axis, const MotionLimits& limits) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableProfile(spec_, limits); !s.ok) return s;
  const auto& c = spec_.commands;
  if (Status s =
          exchange(c.set_rate_limit, axis, limits.rate / c.rate_unit, "set rate limit", nullptr);
      !s.ok) {
    return s;
  }
  return exchange(c.set_accel_limit, axis, limits.accel / c.accel_unit, "set acceleration limit",
                  nullptr);
}

Status SerialTable::moveTo(int axis, double angle) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableTarget(spec_, angle); !s.ok) return s;
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  if (Status s = setMode(axis, AxisMode::kPosition); !s.ok) return s;
  return exchange(spec_.commands.demand_position, axis, angle / spec_.commands.angle_unit,
                  "demand position", nullptr);
}

Status SerialTable::rotateBy(int axis, double delta) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (!std::isfinite(delta)) return Status::Error(spec_.name() + ": rotation is not finite");
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  if (Status s = setMode(axis, AxisMode::kPosition); !s.ok) return s;
  // Not retried: a relative rotation whose ack was lost may have started already.
  return exchange(spec_.commands.rotate, axis, delta / spec_.commands.angle_unit, "rotate", nullptr,
                  /*retry=*/false);
}

Status SerialTable::setRate(int axis, double rate) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  if (Status s = checkTableRate(spec_, rate); !s.ok) return s;
  if (Status s = checkMotionAllowed(); !s.ok) return s;
  if (Status s = setMode(axis, AxisMode::kRate); !s.ok) return s;
  return exchange(spec_.commands.demand_rate, axis, rate / spec_.commands.rate_unit, "demand rate",
                  nullptr);
}

Status SerialTable::stop(int axis) {
  if (Status s = checkTableAxis(spec_, axis); !s.ok) return s;
  return exchange(spec_.commands.stop, axis, 0.0, "stop", nullptr);
}

Status SerialTable::emergencyStop() {
  return exchange(spec_.commands.estop, -1, 0.0, "emergency stop", nullptr);
}

Status SerialTable::interlock(InterlockCommand c) {
  const auto& cs = spec_.commands;
  const SerialCommand& cmd = c == InterlockCommand::kClose  ? cs.interlock_close
                             : c == InterlockCommand::kOpen ? cs.interlock_open
                                                            : cs.interlock_reset;
  Status s = exchange(cmd, -1, 0.0, "interlock command", nullptr);
  if (s.ok && c != InterlockCommand::kOpen) status_fault_ = false;
  return s;
}

Status SerialTable::read(TableReading* out) {
  TableReading r;
  double raw = 0;
  if (Status s = query(spec_.commands.read_status, -1, "read status", &raw); !s.ok) return s;
  const std::string fault = decodeTableStatus(spec_.bits, static_cast<uint32_t>(raw), &r);
  r.axes.resize(static_cast<size_t>(spec_.axisCount()));
  for (int i = 0; i < spec_.axisCount(); ++i) {
    auto& a = r.axes[i];
    double v = 0;
    const double asked = unixTimeS();
    if (Status s = query(spec_.commands.read_position, i, "read position", &v); !s.ok) return s;
    {
      const double replied = unixTimeS();
      a.read_unix_s = 0.5 * (asked + replied);
      a.round_trip_s = replied - asked;
    }
    a.angle = v * spec_.commands.angle_unit;
    if (Status s = query(spec_.commands.read_rate, i, "read rate", &v); !s.ok) return s;
    a.rate = v * spec_.commands.rate_unit;
    if (Status s = query(spec_.commands.read_axis_status, i, "read axis status", &v); !s.ok)
      return s;
    const auto st = static_cast<uint32_t>(v);
    a.moving = ((st >> spec_.bits.axis_moving) & 1u) != 0;
    a.in_position = ((st >> spec_.bits.axis_in_position) & 1u) != 0;
  }
  *out = r;
  return latchFault(spec_.name(), fault, sink_, &status_fault_);
}

}  // namespace imubench::drivers
