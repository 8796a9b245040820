#include "drivers/imu_layout.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "drivers/can_frame.h"
#include "drivers/dbc_parser.h"

namespace imubench::drivers {
namespace {

constexpr std::array<const char*, kImuQuantityCount> kNames = {
    "time",   "counter", "status", "temperature", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x",
    "dvel_y", "dvel_z",  "rate_x", "rate_y",      "rate_z",   "accel_x",  "accel_y",  "accel_z"};

bool isRateLike(ImuQuantity q) {
  return q >= ImuQuantity::kRateX && q <= ImuQuantity::kAccelZ;
}

struct UnitEntry {
  const char* unit;
  double si;
};

}  // namespace

const char* imuQuantityName(ImuQuantity q) {
  return kNames[static_cast<std::size_t>(q)];
}

std::optional<ImuQuantity> imuQuantityFromName(std::string_view name) {
  for (int i = 0; i < kImuQuantityCount; ++i)
    if (name == kNames[static_cast<std::size_t>(i)]) return static_cast<ImuQuantity>(i);
  return std::nullopt;
}

std::optional<double> imuUnitToSi(ImuQuantity q, std::string_view unit, std::string* why) {
  constexpr double kDeg = std::numbers::pi / 180.0;
  static const std::vector<UnitEntry> kTime = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}};
  static const std::vector<UnitEntry> kTemp = {{"degC", 1.0},
                                               {"C", 1.0},
                                               {"\xC2\xB0"
                                                "C",
                                                1.0}};
  static const std::vector<UnitEntry> kAngle = {{"rad", 1.0},   {"mrad", 1e-3},
                                                {"urad", 1e-6}, {"nrad", 1e-9},
                                                {"deg", kDeg},  {"arcsec", kDeg / 3600.0}};
  static const std::vector<UnitEntry> kVel = {{"m/s", 1.0}, {"mm/s", 1e-3}, {"um/s", 1e-6}};
  static const std::vector<UnitEntry> kRate = {
      {"rad/s", 1.0}, {"mrad/s", 1e-3}, {"deg/s", kDeg}, {"deg/h", kDeg / 3600.0}};
  static const std::vector<UnitEntry> kAccel = {
      {"m/s^2", 1.0}, {"m/s2", 1.0}, {"m/s\xC2\xB2", 1.0}, {"mm/s^2", 1e-3}, {"g", 9.80665}};
  static const std::vector<UnitEntry> kPlain = {{"", 1.0}, {"1", 1.0}, {"-", 1.0}};
  // The unit list of each quantity, in ImuQuantity order (counter and status: plain numbers).
  static const std::array<const std::vector<UnitEntry>*, kImuQuantityCount> kByQuantity = {
      &kTime, &kPlain, &kPlain, &kTemp, &kAngle, &kAngle, &kAngle, &kVel,
      &kVel,  &kVel,   &kRate,  &kRate, &kRate,  &kAccel, &kAccel, &kAccel};
  const auto i = static_cast<std::size_t>(q);
  const std::vector<UnitEntry>* table = i < kByQuantity.size() ? kByQuantity[i] : &kPlain;
  for (const auto& e : *table)
    if (unit == e.unit) return e.si;
  if (why) {
    std::string list;
    for (const auto& e : *table) list += std::string(list.empty() ? "" : ", ") + "'" + e.unit + "'";
    *why = "unit '" + std::string(unit) + "' is not accepted for " + imuQuantityName(q) +
           " (accepted: " + list + ")";
  }
  return std::nullopt;
}

const ImuSignal* ImuLayout::find(ImuQuantity q, int* message_index) const {
  for (std::size_t m = 0; m < messages.size(); ++m) {
    for (const auto& s : messages[m].signals) {
      if (s.quantity == q) {
        if (message_index) *message_index = static_cast<int>(m);
        return &s;
      }
    }
  }
  return nullptr;
}

double ImuLayout::resolution(ImuQuantity q) const {
  const ImuSignal* s = find(q);
  if (s == nullptr) {
    // Increments may come from rates.
    const int qi = static_cast<int>(q);
    if (q >= ImuQuantity::kDthetaX && q <= ImuQuantity::kDvelZ) {
      const auto rq = static_cast<ImuQuantity>(qi + 6);
      if (find(rq) != nullptr) return resolution(rq);
    }
    return 0.0;
  }
  double step = std::abs(s->coding.factor) * 0.5;
  if (s->coding.type == ValueType::kFloat32) step = 0.5 * std::ldexp(1.0, -23);
  if (s->coding.type == ValueType::kFloat64) step = 0.5 * std::ldexp(1.0, -52);
  return isRateLike(q) ? step * sample_period_s : step;
}

bool ImuLayout::IsValid(std::string* why) const {
  auto bad = [&](std::string w) {
    if (why) *why = std::move(w);
    return false;
  };
  if (!(sample_period_s > 0.0) || !std::isfinite(sample_period_s))
    return bad("sample period must be positive");
  if (messages.empty()) return bad("layout has no messages");
  if (start_message < 0 || start_message >= static_cast<int>(messages.size()))
    return bad("start message index out of range");
  if (messages.size() > 32) return bad("at most 32 messages per sample");
  std::array<int, kImuQuantityCount> seen{};
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const auto& m = messages[i];
    if (m.length < 0 || m.length > 64 || (!m.fd && m.length > 8))
      return bad("message '" + m.name + "': length " + std::to_string(m.length) +
                 (m.fd ? " exceeds 64" : " exceeds 8 on classic CAN (set bus = \"fd\")"));
    if (m.fd && canFdRoundUpLength(m.length) != m.length)
      return bad("message '" + m.name + "': " + std::to_string(m.length) +
                 " is not a CAN FD length (0..8, 12, 16, 20, 24, 32, 48, 64)");
    if (m.id > (m.extended ? 0x1FFFFFFFU : 0x7FFU))
      return bad("message '" + m.name + "': id too large");
    for (std::size_t j = 0; j < i; ++j)
      if (messages[j].id == m.id && messages[j].extended == m.extended)
        return bad("messages '" + messages[j].name + "' and '" + m.name + "' share an id");
    for (const auto& s : m.signals) {
      std::string w;
      if (!s.coding.IsValid(&w)) return bad("signal '" + s.name + "': " + w);
      if (s.coding.bytesNeeded() > m.length)
        return bad("signal '" + s.name + "' does not fit in message '" + m.name + "'");
      if (++seen[static_cast<std::size_t>(s.quantity)] > 1)
        return bad(std::string("quantity '") + imuQuantityName(s.quantity) + "' appears twice");
      if ((s.quantity == ImuQuantity::kCounter || s.quantity == ImuQuantity::kStatus) &&
          (s.coding.type != ValueType::kInteger || s.coding.factor != 1.0 ||
           s.coding.offset != 0.0))
        return bad("signal '" + s.name + "': counter and status must be plain integers");
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    const auto has = [&](ImuQuantity q) { return seen[static_cast<std::size_t>(q)] > 0; };
    const auto ax = [axis](ImuQuantity base) {
      return static_cast<ImuQuantity>(static_cast<int>(base) + axis);
    };
    const bool gyro = has(ax(ImuQuantity::kDthetaX));
    const bool rate = has(ax(ImuQuantity::kRateX));
    const bool dv = has(ax(ImuQuantity::kDvelX));
    const bool acc = has(ax(ImuQuantity::kAccelX));
    if (gyro == rate)
      return bad(std::string("axis ") + "xyz"[axis] + ": need exactly one of dtheta or rate");
    if (dv == acc)
      return bad(std::string("axis ") + "xyz"[axis] + ": need exactly one of dvel or accel");
  }
  int seq_msg = -1;
  if (find(ImuQuantity::kCounter, &seq_msg) || find(ImuQuantity::kTime, &seq_msg)) {
    if (seq_msg != start_message)
      return bad("the counter / time stamp must be in the start message");
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Device files.
namespace {

bool splitQuantity(std::string_view text, double* value, std::string* unit) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  std::size_t sp = text.find(' ');
  std::string_view num = text.substr(0, sp);
  std::string_view u = sp == std::string_view::npos ? std::string_view() : text.substr(sp + 1);
  while (!u.empty() && u.front() == ' ') u.remove_prefix(1);
  while (!u.empty() && u.back() == ' ') u.remove_suffix(1);
  auto r = std::from_chars(num.data(), num.data() + num.size(), *value);
  if (r.ec != std::errc() || r.ptr != num.data() + num.size()) return false;
  *unit = std::string(u);
  return true;
}

struct TypeSpec {
  const char* name;
  int bits;
  bool is_signed;
  ValueType type;
};
constexpr TypeSpec kTypes[] = {
    {"u8", 8, false, ValueType::kInteger},   {"i8", 8, true, ValueType::kInteger},
    {"u16", 16, false, ValueType::kInteger}, {"i16", 16, true, ValueType::kInteger},
    {"u24", 24, false, ValueType::kInteger}, {"i24", 24, true, ValueType::kInteger},
    {"u32", 32, false, ValueType::kInteger}, {"i32", 32, true, ValueType::kInteger},
    {"u64", 64, false, ValueType::kInteger}, {"i64", 64, true, ValueType::kInteger},
    {"f32", 32, true, ValueType::kFloat32},  {"f64", 64, true, ValueType::kFloat64}};

// The value at `key` as a T ("must be <kind>" when it is not); nullopt when it is missing (an
// error when required) or wrong.
template <class T>
std::optional<T> valueField(const toml::table& t, std::string_view key, io::Diagnostics& diag,
                            bool required, std::string_view kind) {
  const toml::node* n = t.get(key);
  if (n == nullptr) {
    if (required) diag.error(t.source(), "missing required key '" + std::string(key) + "'");
    return std::nullopt;
  }
  if (auto v = n->value<T>()) return *v;
  diag.error(n->source(), "'" + std::string(key) + "' must be " + std::string(kind));
  return std::nullopt;
}

std::optional<std::int64_t> intField(const toml::table& t, std::string_view key,
                                     io::Diagnostics& diag, bool required) {
  return valueField<std::int64_t>(t, key, diag, required, "an integer");
}

std::optional<std::string> stringField(const toml::table& t, std::string_view key,
                                       io::Diagnostics& diag, bool required) {
  return valueField<std::string>(t, key, diag, required, "a string");
}

// Scale/offset written as "<number> <unit>" (unit-less for counter and status).
bool scaleField(const toml::table& t, std::string_view key, ImuQuantity q, double def, double* out,
                io::Diagnostics& diag) {
  const toml::node* n = t.get(key);
  if (n == nullptr) {
    *out = def;
    return true;
  }
  if (auto num = n->value<double>();
      num && (q == ImuQuantity::kCounter || q == ImuQuantity::kStatus)) {
    *out = *num;
    return true;
  }
  auto s = n->value<std::string>();
  if (!s) {
    diag.error(n->source(), "'" + std::string(key) + "' must be a string \"<number> <unit>\"");
    return false;
  }
  double v = 0.0;
  std::string unit;
  if (!splitQuantity(*s, &v, &unit)) {
    diag.error(n->source(), "'" + *s + "' is not \"<number> <unit>\"");
    return false;
  }
  std::string why;
  auto si = imuUnitToSi(q, unit, &why);
  if (!si) {
    diag.error(n->source(), why);
    return false;
  }
  *out = v * *si;
  return true;
}

bool parseSignal(const toml::table& st, ImuSignal* sig, io::Diagnostics& diag) {
  auto qname = stringField(st, "quantity", diag, true);
  if (!qname) return false;
  auto q = imuQuantityFromName(*qname);
  if (!q) {
    diag.error(st.get("quantity")->source(), "unknown quantity '" + *qname + "'");
    return false;
  }
  sig->quantity = *q;
  sig->name = stringField(st, "name", diag, false).value_or(*qname);
  const std::string endian = stringField(st, "endian", diag, false).value_or("little");
  if (endian != "little" && endian != "big") {
    diag.error(st.get("endian")->source(), "endian must be \"little\" or \"big\"");
    return false;
  }
  SignalCoding& c = sig->coding;
  c.order = endian == "little" ? ByteOrder::kLittleEndian : ByteOrder::kBigEndian;
  if (st.contains("type")) {
    auto tname = stringField(st, "type", diag, true);
    if (!tname) return false;
    const TypeSpec* ts = nullptr;
    for (const auto& t : kTypes)
      if (*tname == t.name) ts = &t;
    if (ts == nullptr) {
      diag.error(st.get("type")->source(),
                 "unknown type '" + *tname + "' (u8 i8 u16 i16 u24 i24 u32 i32 u64 i64 f32 f64)");
      return false;
    }
    auto byte = intField(st, "byte", diag, true);
    if (!byte) return false;
    if (*byte < 0 || *byte > 63) {
      diag.error(st.get("byte")->source(), "byte offset must be 0..63");
      return false;
    }
    c.length = ts->bits;
    c.is_signed = ts->is_signed;
    c.type = ts->type;
    c.start_bit = static_cast<int>(*byte) * 8 + (c.order == ByteOrder::kBigEndian ? 7 : 0);
  } else {
    // Bit-level placement with DBC semantics.
    auto start = intField(st, "start_bit", diag, true);
    auto bits = intField(st, "bits", diag, true);
    if (!start || !bits) return false;
    c.start_bit = static_cast<int>(*start);
    c.length = static_cast<int>(*bits);
    if (const toml::node* sn = st.get("signed")) {
      auto b = sn->value<bool>();
      if (!b) {
        diag.error(sn->source(), "'signed' must be true or false");
        return false;
      }
      c.is_signed = *b;
    }
  }
  if (!scaleField(st, "scale", *q, 1.0, &c.factor, diag)) return false;
  if (!scaleField(st, "offset", *q, 0.0, &c.offset, diag)) return false;
  if ((*q != ImuQuantity::kCounter && *q != ImuQuantity::kStatus) && !st.contains("scale") &&
      c.type == ValueType::kInteger) {
    diag.error(st.source(), "integer signal '" + sig->name +
                                "' needs a scale with its unit, e.g. scale = \"0.01 m/s^2\"");
    return false;
  }
  std::string why;
  if (!c.IsValid(&why)) {
    diag.error(st.source(), "signal '" + sig->name + "': " + why);
    return false;
  }
  return true;
}

bool layoutFromMessages(const toml::table& root, bool fd, ImuLayout* layout,
                        io::Diagnostics& diag) {
  const toml::array* arr = root.get_as<toml::array>("message");
  if (arr == nullptr || arr->empty()) {
    diag.error(root.source(), "device file needs either 'dbc' or at least one [[message]]");
    return false;
  }
  bool ok = true;
  for (const toml::node& mn : *arr) {
    const toml::table* mt = mn.as_table();
    if (mt == nullptr) {
      diag.error(mn.source(), "[[message]] entries must be tables");
      ok = false;
      continue;
    }
    ImuMessage m;
    m.fd = fd;
    auto name = stringField(*mt, "name", diag, true);
    auto id = intField(*mt, "id", diag, true);
    auto len = intField(*mt, "length", diag, true);
    if (!name || !id || !len) {
      ok = false;
      continue;
    }
    m.name = *name;
    if (const toml::node* en = mt->get("extended")) m.extended = en->value<bool>().value_or(false);
    if (*id < 0 || *id > (m.extended ? 0x1FFFFFFF : 0x7FF)) {
      diag.error(
          mt->get("id")->source(),
          "id out of range for a " + std::string(m.extended ? "29" : "11") + "-bit identifier");
      ok = false;
      continue;
    }
    m.id = static_cast<std::uint32_t>(*id);
    m.length = static_cast<int>(*len);
    if (const toml::array* sigs = mt->get_as<toml::array>("signal")) {
      for (const toml::node& sn : *sigs) {
        const toml::table* st = sn.as_table();
        ImuSignal sig;
        if (st == nullptr || !parseSignal(*st, &sig, diag)) {
          ok = false;
          continue;
        }
        if (sig.coding.bytesNeeded() > m.length) {
          diag.error(st->source(), "signal '" + sig.name + "' does not fit in " +
                                       std::to_string(m.length) + " bytes");
          ok = false;
          continue;
        }
        m.signals.push_back(std::move(sig));
      }
    }
    if (mt->get("starts_sample") && mt->get("starts_sample")->value<bool>().value_or(false))
      layout->start_message = static_cast<int>(layout->messages.size());
    layout->messages.push_back(std::move(m));
  }
  return ok;
}

bool layoutFromDbc(const toml::table& root, const std::string& base_dir, bool fd, ImuLayout* layout,
                   io::Diagnostics& diag) {
  const toml::node* dn = root.get("dbc");
  auto dbc_name = dn->value<std::string>();
  if (!dbc_name) {
    diag.error(dn->source(), "'dbc' must be a file name");
    return false;
  }
  std::filesystem::path p(*dbc_name);
  if (p.is_relative()) p = std::filesystem::path(base_dir) / p;
  io::Diagnostics dbc_diag(p.string());
  auto db = loadDbcFile(p.string(), dbc_diag);
  if (!db) {
    for (const auto& d : dbc_diag.items()) diag.error(dn->source(), "in DBC: " + d.str());
    return false;
  }
  const toml::table* map = root.get_as<toml::table>("signals");
  if (map == nullptr) {
    diag.error(root.source(),
               "a DBC-based device file needs a [signals] table mapping "
               "quantities to \"MESSAGE.SIGNAL\"");
    return false;
  }
  bool ok = true;
  for (const auto& [key, node] : *map) {
    auto q = imuQuantityFromName(key.str());
    auto ref = node.value<std::string>();
    if (!q || !ref) {
      diag.error(node.source(), !q ? "unknown quantity '" + std::string(key.str()) + "'"
                                   : "expected \"MESSAGE.SIGNAL\"");
      ok = false;
      continue;
    }
    const auto dot = ref->find('.');
    const DbcMessage* dm =
        dot == std::string::npos ? nullptr : db->findMessage(ref->substr(0, dot));
    const DbcSignal* ds = dm ? dm->findSignal(ref->substr(dot + 1)) : nullptr;
    if (ds == nullptr) {
      diag.error(node.source(), "'" + *ref + "' is not a MESSAGE.SIGNAL of " + p.string());
      ok = false;
      continue;
    }
    std::string why;
    auto si = imuUnitToSi(*q, ds->unit, &why);
    if (!si) {
      diag.error(node.source(), p.string() + ":" + std::to_string(ds->line) + ": " + why);
      ok = false;
      continue;
    }
    // Find or add the message.
    ImuMessage* m = nullptr;
    for (auto& lm : layout->messages)
      if (lm.id == dm->id && lm.extended == dm->extended) m = &lm;
    if (m == nullptr) {
      ImuMessage nm;
      nm.name = dm->name;
      nm.id = dm->id;
      nm.extended = dm->extended;
      nm.length = dm->length;
      nm.fd = fd || dm->length > 8;
      layout->messages.push_back(std::move(nm));
      m = &layout->messages.back();
    }
    ImuSignal sig;
    sig.name = ds->name;
    sig.quantity = *q;
    sig.coding = ds->coding;
    sig.coding.factor *= *si;
    sig.coding.offset *= *si;
    m->signals.push_back(std::move(sig));
  }
  if (!ok) return false;
  // Messages in the DBC's order (the [signals] table is unordered).
  const auto dbcIndex = [&db](const ImuMessage& m) {
    for (std::size_t i = 0; i < db->messages.size(); ++i)
      if (db->messages[i].id == m.id && db->messages[i].extended == m.extended) return i;
    return db->messages.size();
  };
  std::stable_sort(
      layout->messages.begin(), layout->messages.end(),
      [&](const ImuMessage& x, const ImuMessage& y) { return dbcIndex(x) < dbcIndex(y); });
  if (auto start = stringField(root, "start_message", diag, false)) {
    bool found = false;
    for (std::size_t i = 0; i < layout->messages.size(); ++i) {
      if (layout->messages[i].name == *start) {
        layout->start_message = static_cast<int>(i);
        found = true;
      }
    }
    if (!found) {
      diag.error(root.get("start_message")->source(),
                 "start_message '" + *start + "' carries no mapped signal");
      return false;
    }
  } else {
    int idx = 0;
    if (layout->find(ImuQuantity::kCounter, &idx) || layout->find(ImuQuantity::kTime, &idx))
      layout->start_message = idx;
  }
  return true;
}

}  // namespace

std::optional<ImuLayout> parseImuLayout(std::string_view toml_text, const std::string& base_dir,
                                        io::Diagnostics& diag) {
  auto root = io::parseToml(toml_text, diag);
  if (!root) return std::nullopt;
  auto format = stringField(*root, "format", diag, true);
  if (format && *format != "imubench-imu-can/1") {
    diag.error(root->get("format")->source(), "format must be \"imubench-imu-can/1\"");
    return std::nullopt;
  }
  ImuLayout layout;
  layout.name = stringField(*root, "name", diag, true).value_or("");
  layout.source = stringField(*root, "source", diag, false).value_or("");
  auto period = io::quantityField(*root, "sample_period", io::Dimension::kTime, diag);
  const std::string bus = stringField(*root, "bus", diag, false).value_or("classic");
  if (bus != "classic" && bus != "fd") {
    diag.error(root->get("bus")->source(), "bus must be \"classic\" or \"fd\"");
    return std::nullopt;
  }
  if (!format || !period || !diag.ok()) return std::nullopt;
  layout.sample_period_s = *period;
  if (auto v = intField(*root, "status_ok_mask", diag, false))
    layout.status_ok_mask = static_cast<std::uint64_t>(*v);
  if (auto v = intField(*root, "status_error_mask", diag, false))
    layout.status_error_mask = static_cast<std::uint64_t>(*v);
  const bool fd = bus == "fd";
  const bool ok = root->contains("dbc") ? layoutFromDbc(*root, base_dir, fd, &layout, diag)
                                        : layoutFromMessages(*root, fd, &layout, diag);
  if (!ok || !diag.ok()) return std::nullopt;
  std::string why;
  if (!layout.IsValid(&why)) {
    diag.error(root->source(), why);
    return std::nullopt;
  }
  return layout;
}

std::optional<ImuLayout> loadImuLayoutFile(const std::string& path, io::Diagnostics& diag) {
  auto text = io::readTextFile(path, "device", diag);
  if (!text) return std::nullopt;
  return parseImuLayout(*text, std::filesystem::path(path).parent_path().string(), diag);
}

}  // namespace imubench::drivers
