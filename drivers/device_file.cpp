#include "drivers/device_file.h"

#include <initializer_list>
#include <set>
#include <string_view>
#include <utility>
#include <vector>

#include "io/enum_names.h"

namespace imubench::drivers {

using io::Diagnostics;
using io::Dimension;

constexpr io::Named<TransportKind> kTransportKindNames[] = {
    {TransportKind::kModbusTcp, "modbus-tcp"},
    {TransportKind::kModbusRtu, "modbus-rtu"},
    {TransportKind::kSerialScpi, "serial-scpi"},
};

const char* transportKindName(TransportKind k) {
  return io::nameOf(kTransportKindNames, k, "?");
}

namespace {

using io::boolField;
using io::checkKeys;
using io::intField;
using io::strField;
using io::subTable;

void readInt(const toml::table& t, std::string_view key, int& out, Diagnostics& diag, int64_t lo,
             int64_t hi) {
  if (auto v = intField(t, key, diag, false, lo, hi)) out = static_cast<int>(*v);
}

// One optional key of a table of integers (codes, bit numbers): where it goes, its range.
struct IntKey {
  std::string_view key;
  int* out;
  int64_t lo, hi;
};

// A table of integer keys only: unknown keys refused (`where` names the table), each key
// present read into its place (a key left out keeps the default there).
template <class... Keys>
void readIntTable(const toml::table& t, std::string_view where, Diagnostics& diag,
                  const Keys&... keys) {
  checkKeys(t, {keys.key...}, where, diag);
  (readInt(t, keys.key, *keys.out, diag, keys.lo, keys.hi), ...);
}

// Jerk ("deg/s^3") has no io::Dimension: parse it as an angular acceleration with one more /s.
// A string field that must name one of `choices` (wire name -> value); anything else is an
// error at the field listing the names (`what` prefixes it, default "<key> must be").
template <class V>
std::optional<V> choiceField(const toml::table& t, std::string_view key,
                             std::initializer_list<std::pair<std::string_view, V>> choices,
                             Diagnostics& diag, bool required, const std::string& what = "") {
  auto s = strField(t, key, diag, required);
  if (!s) return std::nullopt;
  std::string names;
  for (const auto& [name, value] : choices) {
    if (*s == name) return value;
    names += (names.empty() ? "\"" : ", \"") + std::string(name) + "\"";
  }
  diag.error(t.get(key)->source(),
             (what.empty() ? std::string(key) + " must be" : what) + " one of " + names);
  return std::nullopt;
}

std::optional<double> jerkField(const toml::table& t, std::string_view key, Diagnostics& diag) {
  const toml::node* n = t.get(key);
  if (!n) return std::nullopt;
  const auto* s = n->as_string();
  std::string text = s ? s->get() : std::string();
  const auto pos = text.rfind("/s^3");
  if (!s || pos == std::string::npos || pos + 4 != text.size()) {
    diag.error(n->source(), "\"" + std::string(key) +
                                "\" must be a jerk like \"100 deg/s^3\" (deg/s^3 or rad/s^3)");
    return std::nullopt;
  }
  text.replace(pos, 4, "/s^2");
  std::string why;
  auto v = io::parseQuantity(text, Dimension::kAngularAccel, &why);
  if (!v) diag.error(n->source(), "\"" + std::string(key) + "\": " + why);
  return v;
}

// A device file read and parsed by `parse` (parseTableDevice, parseChamberDevice).
template <class Spec>
std::optional<Spec> loadDevice(const std::string& path, Diagnostics& diag,
                               std::optional<Spec> (*parse)(std::string_view, Diagnostics&)) {
  auto text = io::readTextFile(path, "device", diag);
  if (!text) return std::nullopt;
  return parse(*text, diag);
}

void parseRetry(const toml::table& t, RetryPolicy& r, Diagnostics& diag) {
  if (auto v = io::quantityField(t, "timeout", Dimension::kTime, diag, true)) {
    if (*v <= 0.0) {
      diag.error(t.get("timeout")->source(), "\"timeout\" must be positive");
    } else {
      r.timeout_s = *v;
    }
  }
  readInt(t, "retries", r.retries, diag, 0, 20);
  if (auto b = boolField(t, "reconnect", diag)) r.reconnect = *b;
}

void parseTransport(const toml::table& root, TransportSpec& tr, bool allow_serial,
                    Diagnostics& diag) {
  const toml::table* t = subTable(root, "transport", diag, true);
  if (!t) return;
  checkKeys(*t,
            {"type", "host", "port", "unit_id", "device", "baud", "parity", "data_bits",
             "stop_bits", "terminator", "timeout", "retries", "reconnect"},
            "[transport]", diag);
  auto type = strField(*t, "type", diag, true);
  if (type) {
    if (*type == "modbus-tcp") {
      tr.kind = TransportKind::kModbusTcp;
    } else if (*type == "modbus-rtu") {
      tr.kind = TransportKind::kModbusRtu;
    } else if (*type == "serial-scpi" && allow_serial) {
      tr.kind = TransportKind::kSerialScpi;
    } else {
      diag.error(t->get("type")->source(), "unknown transport type \"" + *type +
                                               "\": expected modbus-tcp, modbus-rtu" +
                                               (allow_serial ? " or serial-scpi" : ""));
    }
  }
  if (auto h = strField(*t, "host", diag, false)) tr.host = *h;
  readInt(*t, "port", tr.port, diag, 0, 65535);
  readInt(*t, "unit_id", tr.unit_id, diag, 0, 247);
  if (auto d = strField(*t, "device", diag, false)) tr.device = *d;
  if (auto b = intField(*t, "baud", diag, false, 1, 4000000)) {
    static const std::set<int64_t> kBauds = {1200,  2400,  4800,   9600,   19200,
                                             38400, 57600, 115200, 230400, 460800};
    if (!kBauds.count(*b)) {
      diag.error(t->get("baud")->source(),
                 "unsupported baud rate " + std::to_string(*b) + " (1200 ... 460800)");
    }
    tr.baud = static_cast<int>(*b);
  }
  if (auto p = choiceField<char>(*t, "parity", {{"none", 'N'}, {"even", 'E'}, {"odd", 'O'}}, diag,
                                 false)) {
    tr.parity = *p;
  }
  readInt(*t, "data_bits", tr.data_bits, diag, 5, 8);
  readInt(*t, "stop_bits", tr.stop_bits, diag, 1, 2);
  if (auto term = choiceField<std::string_view>(
          *t, "terminator", {{"lf", "\n"}, {"cr", "\r"}, {"crlf", "\r\n"}}, diag, false)) {
    tr.terminator = std::string(*term);
  }
  parseRetry(*t, tr.retry, diag);
}

struct FieldRule {
  std::string_view key;
  bool has_unit;  // a dimensioned value (needs unit/lsb)
  Dimension dim;  // when has_unit
};

void parseRegister(const toml::table& parent, const FieldRule& rule, RegisterField& f,
                   bool required, Diagnostics& diag) {
  const toml::node* n = parent.get(rule.key);
  if (!n) {
    if (required) {
      diag.error(parent.source(), "missing required register \"" + std::string(rule.key) + "\"");
    }
    return;
  }
  const toml::table* t = n->as_table();
  if (!t) {
    diag.error(n->source(), "register \"" + std::string(rule.key) +
                                "\" must be a table like { address = 10, type = \"f32\", "
                                "unit = \"deg\" }");
    return;
  }
  checkKeys(*t, {"address", "type", "bank", "unit", "lsb"},
            "register \"" + std::string(rule.key) + "\"", diag);
  const size_t before = diag.items().size();
  if (auto a = intField(*t, "address", diag, true, 0, 65535)) f.address = static_cast<int>(*a);
  if (auto ty = choiceField<RegisterType>(*t, "type",
                                          {{"u16", RegisterType::kU16},
                                           {"i16", RegisterType::kI16},
                                           {"u32", RegisterType::kU32},
                                           {"i32", RegisterType::kI32},
                                           {"f32", RegisterType::kF32}},
                                          diag, true, "unknown register type: type must be")) {
    f.type = *ty;
  }
  if (auto b = choiceField<RegisterBank>(
          *t, "bank", {{"holding", RegisterBank::kHolding}, {"input", RegisterBank::kInput}}, diag,
          false)) {
    f.bank = *b;
  }
  const toml::node* unit = t->get("unit");
  const toml::node* lsb = t->get("lsb");
  if (!rule.has_unit) {
    if (unit || lsb) {
      diag.error((unit ? unit : lsb)->source(),
                 "register \"" + std::string(rule.key) + "\" holds a code or bits: no unit/lsb");
    }
    if (f.type == RegisterType::kF32) {
      diag.error(t->source(), "register \"" + std::string(rule.key) + "\" must be an integer type");
    }
  } else if (unit && lsb) {
    diag.error(lsb->source(), "give either \"unit\" (f32) or \"lsb\" (integers), not both");
  } else if (unit) {
    if (f.type != RegisterType::kF32) {
      diag.error(unit->source(),
                 "\"unit\" is for f32 registers; integer registers need \"lsb\" "
                 "(the value of one count, e.g. \"0.001 deg\")");
    } else if (!unit->is_string()) {
      diag.error(unit->source(), "\"unit\" must be a string like \"deg\"");
    } else {
      std::string why;
      auto v = io::parseQuantity("1 " + unit->as_string()->get(), rule.dim, &why);
      if (v) {
        f.lsb = *v;
      } else {
        diag.error(unit->source(), "\"unit\": " + why);
      }
    }
  } else if (lsb) {
    if (f.type == RegisterType::kF32) {
      diag.error(lsb->source(), "f32 registers take \"unit\", not \"lsb\"");
    } else if (auto v = io::quantityField(*t, "lsb", rule.dim, diag)) {
      if (*v == 0.0) {
        diag.error(lsb->source(), "\"lsb\" must not be zero");
      } else {
        f.lsb = *v;
      }
    }
  } else {
    diag.error(t->source(), "register \"" + std::string(rule.key) + "\" needs its scaling: " +
                                "\"unit\" for f32 or \"lsb\" for integers");
  }
  f.present = diag.items().size() == before;
}

WordOrder parseWordOrder(const toml::table& t, Diagnostics& diag) {
  return choiceField<WordOrder>(
             t, "word_order",
             {{"high-first", WordOrder::kHighFirst}, {"low-first", WordOrder::kLowFirst}}, diag,
             true)
      .value_or(WordOrder::kHighFirst);
}

// Registers may not overlap: two fields sharing a register is a typo in the map.
struct Claimed {
  std::string key;
  const RegisterField* f;
};
void checkOverlaps(const std::vector<Claimed>& fields, const toml::table& where,
                   Diagnostics& diag) {
  for (size_t i = 0; i < fields.size(); ++i) {
    for (size_t j = i + 1; j < fields.size(); ++j) {
      const auto& a = *fields[i].f;
      const auto& b = *fields[j].f;
      if (!a.present || !b.present || a.bank != b.bank) continue;
      if (a.address < b.address + b.width() && b.address < a.address + a.width()) {
        diag.error(where.source(), "registers \"" + fields[i].key + "\" and \"" + fields[j].key +
                                       "\" overlap at address " +
                                       std::to_string(std::max(a.address, b.address)));
      }
    }
  }
}

void parseTableRegisters(const toml::table& root, TableDeviceSpec& s, Diagnostics& diag) {
  const toml::table* r = subTable(root, "registers", diag, true);
  if (!r) return;
  checkKeys(*r, {"word_order", "status", "control", "axis"}, "[registers]", diag);
  s.registers.word_order = parseWordOrder(*r, diag);
  parseRegister(*r, {"status", false, Dimension::kAngle}, s.registers.status, true, diag);
  parseRegister(*r, {"control", false, Dimension::kAngle}, s.registers.control, true, diag);
  const toml::node* axes = r->get("axis");
  const toml::array* arr = axes ? axes->as_array() : nullptr;
  if (!arr) {
    diag.error(axes ? axes->source() : r->source(),
               "[[registers.axis]] entries required, one per table axis");
    return;
  }
  if (static_cast<int>(arr->size()) != s.axisCount()) {
    diag.error(axes->source(), "table has " + std::to_string(s.axisCount()) + " axes but " +
                                   std::to_string(arr->size()) + " [[registers.axis]] entries");
  }
  std::vector<Claimed> claimed = {{"status", &s.registers.status},
                                  {"control", &s.registers.control},
                                  {"host_watchdog.heartbeat", &s.watchdog.heartbeat}};
  s.registers.axes.resize(arr->size());
  for (size_t i = 0; i < arr->size(); ++i) {
    const toml::table* a = (*arr)[i].as_table();
    if (!a) {
      diag.error((*arr)[i].source(), "[[registers.axis]] entry must be a table");
      continue;
    }
    checkKeys(*a,
              {"mode", "position_demand", "rate_demand", "rotate_by", "command", "position", "rate",
               "status", "rate_limit", "accel_limit"},
              "[[registers.axis]]", diag);
    auto& ax = s.registers.axes[i];
    parseRegister(*a, {"mode", false, Dimension::kAngle}, ax.mode, true, diag);
    parseRegister(*a, {"position_demand", true, Dimension::kAngle}, ax.position_demand, true, diag);
    parseRegister(*a, {"rate_demand", true, Dimension::kRate}, ax.rate_demand, true, diag);
    parseRegister(*a, {"rotate_by", true, Dimension::kAngle}, ax.rotate_by, true, diag);
    parseRegister(*a, {"command", false, Dimension::kAngle}, ax.command, true, diag);
    parseRegister(*a, {"position", true, Dimension::kAngle}, ax.position, true, diag);
    parseRegister(*a, {"rate", true, Dimension::kRate}, ax.rate, true, diag);
    parseRegister(*a, {"status", false, Dimension::kAngle}, ax.status, true, diag);
    parseRegister(*a, {"rate_limit", true, Dimension::kRate}, ax.rate_limit, false, diag);
    parseRegister(*a, {"accel_limit", true, Dimension::kAngularAccel}, ax.accel_limit, false, diag);
    if ((a->get("rate_limit") != nullptr) != (a->get("accel_limit") != nullptr)) {
      diag.error(a->source(),
                 "give both \"rate_limit\" and \"accel_limit\" (the motion profile) or neither");
    }
    const std::string p = "axis[" + std::to_string(i) + "].";
    for (auto [name, f] : {std::pair{"mode", &ax.mode},
                           {"position_demand", &ax.position_demand},
                           {"rate_demand", &ax.rate_demand},
                           {"rotate_by", &ax.rotate_by},
                           {"command", &ax.command},
                           {"position", &ax.position},
                           {"rate", &ax.rate},
                           {"status", &ax.status},
                           {"rate_limit", &ax.rate_limit},
                           {"accel_limit", &ax.accel_limit}}) {
      claimed.push_back({p + name, f});
    }
  }
  checkOverlaps(claimed, *r, diag);
}

// [host_watchdog]: the controller's heartbeat register and its timeout. Modbus only: a
// serial command set would need a heartbeat command, which the ones we speak do not have.
void parseHostWatchdog(const toml::table& root, TableDeviceSpec& s, Diagnostics& diag) {
  const toml::node* n = root.get("host_watchdog");
  if (!n) return;
  if (s.transport.kind == TransportKind::kSerialScpi) {
    diag.error(n->source(),
               "[host_watchdog] needs a Modbus heartbeat register: a serial-scpi command set has "
               "no heartbeat command (docs/devices.md, \"Host watchdog\")");
    return;
  }
  const toml::table* t = subTable(root, "host_watchdog", diag, true);
  if (!t) return;
  checkKeys(*t, {"heartbeat", "timeout"}, "[host_watchdog]", diag);
  RegisterField& hb = s.watchdog.heartbeat;
  parseRegister(*t, {"heartbeat", false, Dimension::kAngle}, hb, true, diag);
  if (hb.present && hb.bank != RegisterBank::kHolding) {
    diag.error(t->get("heartbeat")->source(),
               "register \"heartbeat\" must be a holding register (the host writes it)");
    hb.present = false;
  }
  if (auto v = io::quantityField(*t, "timeout", Dimension::kTime, diag, false)) {
    if (!(*v > 0.0 && *v <= 60.0)) {
      diag.error(t->get("timeout")->source(), "\"timeout\" must be in (0, 60] s");
    } else {
      s.watchdog.timeout_s = *v;
    }
  }
}

void parseCommand(const toml::table& t, std::string_view key, SerialCommand& c, Diagnostics& diag,
                  bool required = true) {
  const toml::node* n = t.get(key);
  if (!n) {
    if (required) diag.error(t.source(), "missing required command \"" + std::string(key) + "\"");
    return;
  }
  if (n->is_string()) {
    c.text = n->as_string()->get();
  } else if (const toml::table* ct = n->as_table()) {
    checkKeys(*ct, {"text", "timeout"}, "command \"" + std::string(key) + "\"", diag);
    if (auto s = strField(*ct, "text", diag, true)) c.text = *s;
    if (auto v = io::quantityField(*ct, "timeout", Dimension::kTime, diag, false)) {
      c.timeout_s = *v;
    }
  } else {
    diag.error(n->source(), "command \"" + std::string(key) +
                                "\" must be a string or { text = \"...\", timeout = \"2 s\" }");
    return;
  }
  if (c.text.empty()) diag.error(n->source(), "command \"" + std::string(key) + "\" is empty");
}

// A command set's unit ("deg", "deg/s"): the SI value of 1.0 in its commands.
void readUnit(const toml::table& c, std::string_view key, Dimension dim, bool required, double& out,
              Diagnostics& diag) {
  const auto u = strField(c, key, diag, required);
  if (!u) return;
  std::string why;
  if (auto v = io::parseQuantity("1 " + *u, dim, &why)) {
    out = *v;
  } else {
    diag.error(c.get(key)->source(), why);
  }
}

// The motion profile commands come together, and set_accel_limit needs accel_unit.
void checkProfileCommands(const toml::table& c, Diagnostics& diag) {
  const toml::node* rate_cmd = c.get("set_rate_limit");
  const toml::node* accel_cmd = c.get("set_accel_limit");
  if ((rate_cmd != nullptr) != (accel_cmd != nullptr)) {
    diag.error((rate_cmd != nullptr ? rate_cmd : accel_cmd)->source(),
               "give both \"set_rate_limit\" and \"set_accel_limit\" (the motion profile) or "
               "neither");
  }
  if (accel_cmd != nullptr && c.get("accel_unit") == nullptr) {
    diag.error(accel_cmd->source(),
               "\"set_accel_limit\" needs \"accel_unit\" (e.g. \"deg/s^2\") in [commands]");
  }
}

void parseTableCommands(const toml::table& root, TableDeviceSpec& s, Diagnostics& diag) {
  const toml::table* c = subTable(root, "commands", diag, true);
  if (!c) return;
  auto& cs = s.commands;
  checkKeys(*c,
            {"axis_base",
             "angle_unit",
             "rate_unit",
             "accel_unit",
             "ack",
             "error_prefix",
             "mode_off",
             "mode_position",
             "mode_rate",
             "demand_position",
             "demand_rate",
             "rotate",
             "stop",
             "estop",
             "read_position",
             "read_rate",
             "read_status",
             "read_axis_status",
             "interlock_close",
             "interlock_open",
             "interlock_reset",
             "set_rate_limit",
             "set_accel_limit"},
            "[commands]", diag);
  readInt(*c, "axis_base", cs.axis_base, diag, 0, 9);
  readUnit(*c, "angle_unit", Dimension::kAngle, true, cs.angle_unit, diag);
  readUnit(*c, "rate_unit", Dimension::kRate, true, cs.rate_unit, diag);
  readUnit(*c, "accel_unit", Dimension::kAngularAccel, false, cs.accel_unit, diag);
  if (auto a = strField(*c, "ack", diag, false)) cs.ack = *a;
  if (auto e = strField(*c, "error_prefix", diag, false)) cs.error_prefix = *e;
  struct Entry {
    std::string_view key;
    SerialCommand* cmd;
    bool axis;   // must contain {axis}
    bool value;  // must contain {value}
    bool required = true;
  };
  const Entry entries[] = {
      {"mode_off", &cs.mode_off, true, false},
      {"mode_position", &cs.mode_position, true, false},
      {"mode_rate", &cs.mode_rate, true, false},
      {"demand_position", &cs.demand_position, true, true},
      {"demand_rate", &cs.demand_rate, true, true},
      {"rotate", &cs.rotate, true, true},
      {"stop", &cs.stop, true, false},
      {"estop", &cs.estop, false, false},
      {"read_position", &cs.read_position, true, false},
      {"read_rate", &cs.read_rate, true, false},
      {"read_status", &cs.read_status, false, false},
      {"read_axis_status", &cs.read_axis_status, true, false},
      {"interlock_close", &cs.interlock_close, false, false},
      {"interlock_open", &cs.interlock_open, false, false},
      {"interlock_reset", &cs.interlock_reset, false, false},
      {"set_rate_limit", &cs.set_rate_limit, true, true, false},
      {"set_accel_limit", &cs.set_accel_limit, true, true, false},
  };
  for (const auto& e : entries) {
    parseCommand(*c, e.key, *e.cmd, diag, e.required);
    if (e.cmd->text.empty()) continue;
    const bool has_axis = e.cmd->text.find("{axis}") != std::string::npos;
    const bool has_value = e.cmd->text.find("{value}") != std::string::npos;
    const toml::node* n = c->get(e.key);
    if (has_axis != e.axis) {
      diag.error(n->source(),
                 "command \"" + std::string(e.key) +
                     (e.axis ? "\" must contain {axis}" : "\" must not contain {axis}"));
    }
    if (has_value != e.value) {
      diag.error(n->source(),
                 "command \"" + std::string(e.key) +
                     (e.value ? "\" must contain {value}" : "\" must not contain {value}"));
    }
  }
  checkProfileCommands(*c, diag);
}

void parseStatusBits(const toml::table& root, TableStatusBits& b, Diagnostics& diag) {
  const toml::table* t = subTable(root, "status_bits", diag, false);
  if (!t) return;
  readIntTable(*t, "[status_bits]", diag, IntKey{"interlock_closed", &b.interlock_closed, 0, 15},
               IntKey{"interlock_tripped", &b.interlock_tripped, 0, 15},
               IntKey{"estop", &b.estop, 0, 15}, IntKey{"fault", &b.fault, 0, 15},
               IntKey{"axis_moving", &b.axis_moving, 0, 15},
               IntKey{"axis_in_position", &b.axis_in_position, 0, 15});
  const int g[] = {b.interlock_closed, b.interlock_tripped, b.estop, b.fault};
  if (std::set<int>(std::begin(g), std::end(g)).size() != 4) {
    diag.error(t->source(), "global status bits must be distinct");
  }
  if (b.axis_moving == b.axis_in_position) {
    diag.error(t->source(), "axis status bits must be distinct");
  }
}

void parseTableCodes(const toml::table& root, TableCodes& c, Diagnostics& diag) {
  const toml::table* t = subTable(root, "codes", diag, false);
  if (!t) return;
  readIntTable(
      *t, "[codes]", diag, IntKey{"mode_off", &c.mode_off, 0, 65535},
      IntKey{"mode_position", &c.mode_position, 0, 65535},
      IntKey{"mode_rate", &c.mode_rate, 0, 65535}, IntKey{"cmd_move", &c.cmd_move, 1, 65535},
      IntKey{"cmd_rotate", &c.cmd_rotate, 1, 65535}, IntKey{"cmd_stop", &c.cmd_stop, 1, 65535},
      IntKey{"ctl_estop", &c.ctl_estop, 1, 65535},
      IntKey{"ctl_interlock_close", &c.ctl_interlock_close, 1, 65535},
      IntKey{"ctl_interlock_open", &c.ctl_interlock_open, 1, 65535},
      IntKey{"ctl_interlock_reset", &c.ctl_interlock_reset, 1, 65535});
  const int modes[] = {c.mode_off, c.mode_position, c.mode_rate};
  const int cmds[] = {c.cmd_move, c.cmd_rotate, c.cmd_stop};
  const int ctls[] = {c.ctl_estop, c.ctl_interlock_close, c.ctl_interlock_open,
                      c.ctl_interlock_reset};
  if (std::set<int>(std::begin(modes), std::end(modes)).size() != 3 ||
      std::set<int>(std::begin(cmds), std::end(cmds)).size() != 3 ||
      std::set<int>(std::begin(ctls), std::end(ctls)).size() != 4) {
    diag.error(t->source(), "codes of one register (mode, cmd, ctl) must be distinct");
  }
}

void parseDeviceHeader(const toml::table& root, std::string_view kind, std::string& vendor,
                       std::string& model, Diagnostics& diag, std::string* based_on = nullptr) {
  const toml::table* d = subTable(root, "device", diag, true);
  if (!d) return;
  if (based_on) {
    checkKeys(*d, {"kind", "vendor", "model", "axes", "based_on"}, "[device]", diag);
  } else {
    checkKeys(*d, {"kind", "vendor", "model", "axes"}, "[device]", diag);
  }
  if (auto k = strField(*d, "kind", diag, true); k && *k != kind) {
    diag.error(
        d->get("kind")->source(),
        "this is a \"" + *k + "\" device file; expected kind = \"" + std::string(kind) + "\"");
  }
  if (auto v = strField(*d, "vendor", diag, true)) vendor = *v;
  if (auto m = strField(*d, "model", diag, true)) model = *m;
  if (based_on) {
    if (auto b = strField(*d, "based_on", diag, false)) *based_on = *b;
  }
}

}  // namespace

bool TableDeviceSpec::profileSettable() const {
  if (transport.kind == TransportKind::kSerialScpi) {
    return !commands.set_rate_limit.text.empty() && !commands.set_accel_limit.text.empty();
  }
  if (registers.axes.empty()) return false;
  for (const TableAxisRegisters& a : registers.axes) {
    if (!a.rate_limit.present || !a.accel_limit.present) return false;
  }
  return true;
}

std::optional<TableDeviceSpec> parseTableDevice(std::string_view text, Diagnostics& diag) {
  auto root = io::parseToml(text, diag);
  if (!root) return std::nullopt;
  TableDeviceSpec s;
  s.file = diag.file();
  checkKeys(*root,
            {"device", "transport", "limits", "registers", "commands", "codes", "status_bits",
             "host_watchdog"},
            "the device file", diag);
  parseDeviceHeader(*root, "table", s.vendor, s.model, diag);
  if (const toml::table* d = root->get_as<toml::table>("device")) {
    if (auto a = intField(*d, "axes", diag, true, 2, 3)) {
      s.kind = *a == 2 ? calib::TableKind::kTwoAxis : calib::TableKind::kThreeAxis;
    }
  }
  parseTransport(*root, s.transport, true, diag);
  if (const toml::table* l = subTable(*root, "limits", diag, true)) {
    checkKeys(*l, {"max_rate", "max_accel", "max_jerk", "position_min", "position_max"}, "[limits]",
              diag);
    if (auto v = io::quantityField(*l, "max_rate", Dimension::kRate, diag)) {
      if (*v <= 0) diag.error(l->get("max_rate")->source(), "max_rate must be positive");
      s.limits.max_rate = *v;
    }
    if (auto v = io::quantityField(*l, "max_accel", Dimension::kAngularAccel, diag)) {
      if (*v <= 0) diag.error(l->get("max_accel")->source(), "max_accel must be positive");
      s.limits.max_accel = *v;
    }
    if (auto v = jerkField(*l, "max_jerk", diag)) s.limits.max_jerk = *v;
    auto lo = io::quantityField(*l, "position_min", Dimension::kAngle, diag, false);
    auto hi = io::quantityField(*l, "position_max", Dimension::kAngle, diag, false);
    if (lo.has_value() != hi.has_value()) {
      diag.error(l->source(),
                 "give both position_min and position_max (limited travel) or "
                 "neither (continuous rotation)");
    } else if (lo && hi) {
      if (*lo >= *hi)
        diag.error(l->get("position_max")->source(), "position_max must be above position_min");
      s.limits.limited_travel = true;
      s.limits.position_min = *lo;
      s.limits.position_max = *hi;
    }
  }
  parseTableCodes(*root, s.codes, diag);
  parseStatusBits(*root, s.bits, diag);
  parseHostWatchdog(*root, s, diag);
  if (diag.ok()) {
    if (s.transport.kind == TransportKind::kSerialScpi) {
      if (root->get("registers")) {
        diag.error(root->get("registers")->source(),
                   "a serial-scpi device takes [commands], not [registers]");
      }
      parseTableCommands(*root, s, diag);
    } else {
      if (root->get("commands")) {
        diag.error(root->get("commands")->source(),
                   "a Modbus device takes [registers], not [commands]");
      }
      parseTableRegisters(*root, s, diag);
    }
  }
  if (!diag.ok()) return std::nullopt;
  return s;
}

std::optional<TableDeviceSpec> loadTableDevice(const std::string& path, Diagnostics& diag) {
  return loadDevice(path, diag, parseTableDevice);
}

std::optional<ChamberDeviceSpec> parseChamberDevice(std::string_view text, Diagnostics& diag) {
  auto root = io::parseToml(text, diag);
  if (!root) return std::nullopt;
  ChamberDeviceSpec s;
  s.file = diag.file();
  checkKeys(*root, {"device", "transport", "limits", "registers", "codes", "alarm_bits"},
            "the device file", diag);
  parseDeviceHeader(*root, "chamber", s.vendor, s.model, diag, &s.based_on);
  parseTransport(*root, s.transport, false, diag);
  if (const toml::table* l = subTable(*root, "limits", diag, true)) {
    checkKeys(*l, {"temperature_min", "temperature_max", "max_ramp", "time_constant"}, "[limits]",
              diag);
    auto lo = io::quantityField(*l, "temperature_min", Dimension::kTemperature, diag);
    auto hi = io::quantityField(*l, "temperature_max", Dimension::kTemperature, diag);
    if (lo && hi) {
      if (*lo >= *hi) {
        diag.error(l->get("temperature_max")->source(),
                   "temperature_max must be above temperature_min");
      }
      s.temp_min_c = *lo;
      s.temp_max_c = *hi;
    }
    if (auto v = io::quantityField(*l, "max_ramp", Dimension::kTemperatureRate, diag)) {
      if (*v <= 0) diag.error(l->get("max_ramp")->source(), "max_ramp must be positive");
      s.max_ramp = *v;
    }
    if (auto v = io::quantityField(*l, "time_constant", Dimension::kTime, diag, false)) {
      if (*v <= 0) diag.error(l->get("time_constant")->source(), "time_constant must be positive");
      s.time_constant_s = *v;
    }
  }
  if (const toml::table* c = subTable(*root, "codes", diag, false)) {
    readIntTable(*c, "[codes]", diag, IntKey{"run", &s.codes.run, 0, 65535},
                 IntKey{"stop", &s.codes.stop, 0, 65535});
    if (s.codes.run == s.codes.stop) diag.error(c->source(), "run and stop codes must differ");
  }
  if (const toml::table* b = subTable(*root, "alarm_bits", diag, false)) {
    readIntTable(*b, "[alarm_bits]", diag, IntKey{"high", &s.alarm_bits.high, 0, 15},
                 IntKey{"low", &s.alarm_bits.low, 0, 15},
                 IntKey{"sensor", &s.alarm_bits.sensor, 0, 15});
  }
  if (const toml::table* r = subTable(*root, "registers", diag, true)) {
    checkKeys(*r, {"word_order", "setpoint", "temperature", "ramp_rate", "run", "alarms"},
              "[registers]", diag);
    auto& m = s.registers;
    m.word_order = parseWordOrder(*r, diag);
    parseRegister(*r, {"setpoint", true, Dimension::kTemperature}, m.setpoint, true, diag);
    parseRegister(*r, {"temperature", true, Dimension::kTemperature}, m.temperature, true, diag);
    parseRegister(*r, {"ramp_rate", true, Dimension::kTemperatureRate}, m.ramp_rate, true, diag);
    parseRegister(*r, {"run", false, Dimension::kAngle}, m.run, true, diag);
    parseRegister(*r, {"alarms", false, Dimension::kAngle}, m.alarms, true, diag);
    checkOverlaps({{"setpoint", &m.setpoint},
                   {"temperature", &m.temperature},
                   {"ramp_rate", &m.ramp_rate},
                   {"run", &m.run},
                   {"alarms", &m.alarms}},
                  *r, diag);
  }
  if (!diag.ok()) return std::nullopt;
  return s;
}

std::optional<ChamberDeviceSpec> loadChamberDevice(const std::string& path, Diagnostics& diag) {
  return loadDevice(path, diag, parseChamberDevice);
}

}  // namespace imubench::drivers
