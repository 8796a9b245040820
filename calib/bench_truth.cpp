#include "calib/bench_truth.h"

#include <cmath>
#include <cstdint>

namespace imubench::calib {
namespace {

using nlohmann::json;

const char* const kXYZ[] = {"x", "y", "z"};
const char* const kSigmaKey = "sigma";
const char* const kObservableKey = "observable";

double* misField(Misalignment& m, int i) {
  double* f[] = {&m.xy, &m.xz, &m.yx, &m.yz, &m.zx, &m.zy};
  return f[i];
}

// ---- A flat, named view of every scalar: the one place that knows the layout. -----------
// Each entry: flat name, JSON group path, key within the group, element index in the key's
// value (-1 scalar or misalignment member), a pointer to the double.
struct Slot {
  std::string name;   // "accel.bias.x"
  std::string group;  // "accel", "table", "extra.lever_arm"
  std::string key;    // "bias", "misalignment", "r_m"
  std::string sub;    // misalignment member "xy" (object element) or "" (array/scalar)
  int index = -1;     // array element, row-major for matrices; -1 for scalars/objects
  int rows = 0;       // >0: matrix element (index = row * 3 + col)
  double* value = nullptr;
};

void triadSlots(const std::string& g, TriadModel& t, std::vector<Slot>* out) {
  for (int i = 0; i < 3; ++i)
    out->push_back({g + ".scale." + kXYZ[i], g, "scale", "", i, 0, &t.scale[i]});
  for (int i = 0; i < 3; ++i)
    out->push_back({g + ".bias." + kXYZ[i], g, "bias", "", i, 0, &t.bias[i]});
  for (int i = 0; i < 6; ++i) {
    out->push_back({g + ".misalignment." + model::kMisEntries[static_cast<std::size_t>(i)].name, g,
                    "misalignment", model::kMisEntries[static_cast<std::size_t>(i)].name, -1, 0,
                    misField(t.mis, i)});
  }
}

std::vector<Slot> slots(BenchTruth& t) {
  std::vector<Slot> s;
  triadSlots("accel", t.sensors.accel, &s);
  triadSlots("gyro", t.sensors.gyro, &s);
  TableErrors& e = t.table;
  s.push_back({"table.base_tilt.x", "table", "base_tilt", "", 0, 0, &e.base_tilt[0]});
  s.push_back({"table.base_tilt.y", "table", "base_tilt", "", 1, 0, &e.base_tilt[1]});
  if (t.table_kind == TableKind::kTwoAxis) {
    s.push_back({"table.nonorthogonality.inner_y", "table", "nonorthogonality", "", 0, 0,
                 &e.nonorthogonality.inner_y});
  } else {
    s.push_back({"table.nonorthogonality.middle_x", "table", "nonorthogonality", "", 0, 0,
                 &e.nonorthogonality.middle_x});
    s.push_back({"table.nonorthogonality.middle_y", "table", "nonorthogonality", "", 1, 0,
                 &e.nonorthogonality.middle_y});
    s.push_back({"table.nonorthogonality.inner_y", "table", "nonorthogonality", "", 2, 0,
                 &e.nonorthogonality.inner_y});
  }
  s.push_back({"table.mounting.x", "table", "mounting", "", 0, 0, &e.mounting[0]});
  s.push_back({"table.mounting.y", "table", "mounting", "", 1, 0, &e.mounting[1]});
  s.push_back(
      {"table.encoder_zero.outer", "table", "encoder_zero", "", 0, 0, &e.encoder_zero.outer});
  if (t.table_kind == TableKind::kTwoAxis) {
    s.push_back(
        {"table.encoder_zero.inner", "table", "encoder_zero", "", 1, 0, &e.encoder_zero.inner});
  } else {
    s.push_back(
        {"table.encoder_zero.middle", "table", "encoder_zero", "", 1, 0, &e.encoder_zero.middle});
    s.push_back(
        {"table.encoder_zero.inner", "table", "encoder_zero", "", 2, 0, &e.encoder_zero.inner});
  }
  return s;
}

std::string kindText(const json& v) {
  switch (v.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::string:
      return "a string";
    case json::value_t::array:
      return "an array";
    case json::value_t::object:
      return "an object";
    case json::value_t::discarded:
      return "nothing";
    default:
      return "a number";
  }
}

bool fail(std::string* why, const std::string& path, const std::string& msg) {
  if (why) *why = path + ": " + msg;
  return false;
}

bool readNumber(const json& v, const std::string& path, double* out, std::string* why) {
  if (!v.is_number()) return fail(why, path, "expected a number, got " + kindText(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) return fail(why, path, "not a finite number");
  *out = d;
  return true;
}

bool readArray(const json& v, const std::string& path, int n, double* out, std::string* why) {
  if (!v.is_array())
    return fail(why, path,
                "expected an array of " + std::to_string(n) + " numbers, got " + kindText(v));
  if (static_cast<int>(v.size()) != n) {
    return fail(why, path,
                "expected " + std::to_string(n) + " numbers, got " + std::to_string(v.size()));
  }
  for (int i = 0; i < n; ++i) {
    if (!readNumber(v[static_cast<std::size_t>(i)], path + "[" + std::to_string(i) + "]", &out[i],
                    why))
      return false;
  }
  return true;
}

bool requireObject(const json& v, const std::string& path, std::string* why) {
  if (!v.is_object()) return fail(why, path, "expected an object, got " + kindText(v));
  return true;
}

bool readTriad(const json& j, const std::string& g, TriadModel* t, std::string* why) {
  if (!requireObject(j, g, why)) return false;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const std::string path = g + "." + key;
    if (key == "scale") {
      if (!readArray(*it, path, 3, t->scale.data(), why)) return false;
    } else if (key == "bias") {
      if (!readArray(*it, path, 3, t->bias.data(), why)) return false;
    } else if (key == "misalignment") {
      if (!requireObject(*it, path, why)) return false;
      for (auto m = it->begin(); m != it->end(); ++m) {
        int idx = -1;
        for (int i = 0; i < 6; ++i) {
          if (m.key() == model::kMisEntries[static_cast<std::size_t>(i)].name) idx = i;
        }
        if (idx < 0)
          return fail(why, path + "." + m.key(),
                      "unknown misalignment (expected xy, xz, yx, yz, zx or zy)");
        if (!readNumber(*m, path + "." + m.key(), misField(t->mis, idx), why)) return false;
      }
    } else if (key == kSigmaKey || key == kObservableKey) {
      continue;
    } else {
      return fail(why, path, "unknown key (expected scale, bias, misalignment)");
    }
  }
  for (int i = 0; i < 3; ++i) {
    if (t->scale[i] == 0.0)
      return fail(why, g + ".scale[" + std::to_string(i) + "]", "scale factor must not be zero");
  }
  return true;
}

bool readTable(const json& j, BenchTruth* t, std::string* why) {
  if (!requireObject(j, "table", why)) return false;
  // The kind follows from the array lengths of nonorthogonality / encoder_zero.
  std::optional<TableKind> kind;
  auto kindFrom = [&](const char* key, std::size_t two, std::size_t three) -> bool {
    const auto it = j.find(key);
    if (it == j.end()) return true;
    const std::string path = std::string("table.") + key;
    if (!it->is_array()) return fail(why, path, "expected an array, got " + kindText(*it));
    TableKind k;
    if (it->size() == two) {
      k = TableKind::kTwoAxis;
    } else if (it->size() == three) {
      k = TableKind::kThreeAxis;
    } else {
      return fail(why, path,
                  "expected " + std::to_string(two) + " (two-axis) or " + std::to_string(three) +
                      " (three-axis) numbers, got " + std::to_string(it->size()));
    }
    if (kind && *kind != k)
      return fail(why, path,
                  "length disagrees with the table kind implied by the other table keys");
    kind = k;
    return true;
  };
  if (!kindFrom("nonorthogonality", 1, 3) || !kindFrom("encoder_zero", 2, 3)) return false;
  t->table_kind = kind.value_or(TableKind::kTwoAxis);
  const bool two = t->table_kind == TableKind::kTwoAxis;
  TableErrors& e = t->table;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const std::string path = "table." + key;
    if (key == "base_tilt") {
      if (!readArray(*it, path, 2, e.base_tilt.data(), why)) return false;
    } else if (key == "mounting") {
      if (!readArray(*it, path, 2, e.mounting.data(), why)) return false;
    } else if (key == "nonorthogonality") {
      double v[3] = {0, 0, 0};
      if (!readArray(*it, path, two ? 1 : 3, v, why)) return false;
      if (two) {
        e.nonorthogonality = {v[0], 0.0, 0.0};
      } else {
        e.nonorthogonality = {v[2], v[0], v[1]};
      }
    } else if (key == "encoder_zero") {
      double v[3] = {0, 0, 0};
      if (!readArray(*it, path, two ? 2 : 3, v, why)) return false;
      e.encoder_zero = two ? EncoderZero{v[0], 0.0, v[1]} : EncoderZero{v[0], v[1], v[2]};
    } else if (key == kSigmaKey || key == kObservableKey) {
      continue;
    } else {
      return fail(why, path,
                  "unknown key (expected base_tilt, nonorthogonality, mounting, encoder_zero)");
    }
  }
  return true;
}

// A scalar effect parameter: a number, or a table axis name for ParamKind::kTableAxis (the
// range of discrete values is checked by EffectSet::setParam).
bool readScalarParam(const json& v, const std::string& path, ParamKind kind, double* out,
                     std::string* why) {
  if (kind != ParamKind::kTableAxis) return readNumber(v, path, out, why);
  const std::optional<int> axis =
      v.is_string() ? tableAxisFromName(v.get<std::string>()) : std::nullopt;
  if (!axis) return fail(why, path, "expected \"outer\", \"middle\" or \"inner\"");
  *out = *axis;
  return true;
}

bool readExtra(const json& j, EffectSet* fx, std::string* why) {
  if (!requireObject(j, "extra", why)) return false;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string path = "extra." + it.key();
    const auto id = effectFromName(it.key());
    if (!id) return fail(why, path, "unknown effect id");
    if (!requireObject(*it, path, why)) return false;
    fx->enable(*id);
    for (auto p = it->begin(); p != it->end(); ++p) {
      const std::string ppath = path + "." + p.key();
      if (p.key() == kSigmaKey || p.key() == kObservableKey) continue;
      const ParamSpec* spec = nullptr;
      for (const ParamSpec& s : paramSpecs(*id)) {
        if (p.key() == s.name) spec = &s;
      }
      if (!spec) return fail(why, ppath, "unknown parameter of effect " + it.key());
      double v[9] = {};
      switch (spec->shape) {
        case ParamShape::kScalar:
          if (!readScalarParam(*p, ppath, spec->kind, v, why)) return false;
          break;
        case ParamShape::kVec3:
          if (!readArray(*p, ppath, 3, v, why)) return false;
          break;
        case ParamShape::kMat3:
          if (!p->is_array() || p->size() != 3)
            return fail(why, ppath, "expected a 3x3 matrix (three rows of three numbers)");
          for (int r = 0; r < 3; ++r) {
            if (!readArray((*p)[static_cast<std::size_t>(r)], ppath + "[" + std::to_string(r) + "]",
                           3, v + 3 * r, why))
              return false;
          }
          break;
      }
      std::string err;
      if (!fx->setParam(
              *id, spec->name,
              std::span<const double>(v, static_cast<std::size_t>(paramSize(spec->shape))), &err)) {
        return fail(why, ppath, err);
      }
    }
  }
  return true;
}

json paramJson(const ParamSpec& spec, const std::vector<double>& v) {
  switch (spec.shape) {
    case ParamShape::kScalar:
      if (spec.kind == ParamKind::kTableAxis) return tableAxisName(static_cast<int>(v[0]));
      if (spec.kind == ParamKind::kInteger) return static_cast<std::int64_t>(v[0]);
      return v[0];
    case ParamShape::kVec3:
      return json::array({v[0], v[1], v[2]});
    case ParamShape::kMat3:
      return json::array({json::array({v[0], v[1], v[2]}), json::array({v[3], v[4], v[5]}),
                          json::array({v[6], v[7], v[8]})});
  }
  return v[0];
}

// Sets element `index` of a same-shaped JSON value inside an object at `key` (creating it).
void putShaped(json& group, const Slot& s, const json& value, const json& fill) {
  json& k = group[s.key];
  if (!s.sub.empty()) {
    if (!k.is_object()) k = json::object();
    k[s.sub] = value;
    return;
  }
  if (s.index < 0) {
    k = value;
    return;
  }
  if (s.rows > 0) {
    if (!k.is_array())
      k = json::array({json::array({fill, fill, fill}), json::array({fill, fill, fill}),
                       json::array({fill, fill, fill})});
    k[static_cast<std::size_t>(s.index / 3)][static_cast<std::size_t>(s.index % 3)] = value;
    return;
  }
  if (!k.is_array()) k = json::array();
  while (k.size() <= static_cast<std::size_t>(s.index)) k.push_back(fill);
  k[static_cast<std::size_t>(s.index)] = value;
}

const json* getShaped(const json& group, const Slot& s) {
  const auto k = group.find(s.key);
  if (k == group.end()) return nullptr;
  if (!s.sub.empty()) {
    if (!k->is_object()) return nullptr;
    const auto m = k->find(s.sub);
    return m == k->end() ? nullptr : &*m;
  }
  if (s.index < 0) return &*k;
  if (s.rows > 0) {
    const std::size_t r = static_cast<std::size_t>(s.index / 3),
                      c = static_cast<std::size_t>(s.index % 3);
    if (!k->is_array() || k->size() <= r || !(*k)[r].is_array() || (*k)[r].size() <= c)
      return nullptr;
    return &(*k)[r][c];
  }
  if (!k->is_array() || k->size() <= static_cast<std::size_t>(s.index)) return nullptr;
  return &(*k)[static_cast<std::size_t>(s.index)];
}

json& groupAt(json& root, const std::string& group) {
  if (group.rfind("extra.", 0) == 0) return root["extra"][group.substr(6)];
  return root[group];
}
const json* groupAt(const json& root, const std::string& group) {
  if (group.rfind("extra.", 0) == 0) {
    const auto e = root.find("extra");
    if (e == root.end() || !e->is_object()) return nullptr;
    const auto g = e->find(group.substr(6));
    return g == e->end() ? nullptr : &*g;
  }
  const auto g = root.find(group);
  return g == root.end() ? nullptr : &*g;
}

// Slots of the extra effects (enabled ones). Values live in `storage` (flat copies) since the
// effect structs are reached through EffectSet's generic access.
struct ExtraSlots {
  std::vector<Slot> slots;
  std::vector<std::pair<EffectId, std::vector<double>>> storage;
};

ExtraSlots extraSlots(const EffectSet& fx) {
  ExtraSlots x;
  x.storage.reserve(kEffectCount);
  for (EffectId id : fx.enabled()) x.storage.emplace_back(id, fx.flat(id));
  for (auto& [id, values] : x.storage) {
    const std::vector<std::string> names = flatParamNames(id);
    const std::string group = std::string("extra.") + effectName(id);
    std::size_t k = 0;
    for (const ParamSpec& p : paramSpecs(id)) {
      const int n = paramSize(p.shape);
      for (int e = 0; e < n; ++e, ++k) {
        Slot s{"extra." + names[k],
               group,
               p.name,
               "",
               p.shape == ParamShape::kScalar ? -1 : e,
               p.shape == ParamShape::kMat3 ? 3 : 0,
               &values[k]};
        x.slots.push_back(s);
      }
    }
  }
  return x;
}

}  // namespace

nlohmann::json toJson(const BenchTruth& truth_in) {
  BenchTruth truth = truth_in;  // slots() needs mutable storage; cheap
  json j;
  for (const Slot& s : slots(truth)) putShaped(groupAt(j, s.group), s, *s.value, 0.0);
  json extra = json::object();
  for (EffectId id : truth.extra.enabled()) {
    json e = json::object();
    for (const ParamSpec& p : paramSpecs(id)) {
      e[p.name] = paramJson(p, *truth.extra.param(id, p.name));
    }
    extra[effectName(id)] = e;
  }
  j["extra"] = extra;
  return j;
}

bool fromJson(const nlohmann::json& j, BenchTruth* truth, std::string* why) {
  BenchTruth t;
  if (!j.is_object()) return fail(why, "(root)", "expected an object, got " + kindText(j));
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    if (key == "accel") {
      if (!readTriad(*it, "accel", &t.sensors.accel, why)) return false;
    } else if (key == "gyro") {
      if (!readTriad(*it, "gyro", &t.sensors.gyro, why)) return false;
    } else if (key == "table") {
      if (!readTable(*it, &t, why)) return false;
    } else if (key == "extra") {
      if (!readExtra(*it, &t.extra, why)) return false;
    } else {
      return fail(why, key, "unknown key (expected accel, gyro, table, extra)");
    }
  }
  *truth = t;
  return true;
}

std::vector<std::string> flatNames(const BenchTruth& truth_in) {
  BenchTruth truth = truth_in;
  std::vector<std::string> names;
  for (const Slot& s : slots(truth)) names.push_back(s.name);
  for (EffectId id : truth.extra.enabled()) {
    for (const std::string& n : flatParamNames(id)) names.push_back("extra." + n);
  }
  return names;
}

std::vector<std::string> tableFlatNames(TableKind kind) {
  BenchTruth t;
  t.table_kind = kind;
  std::vector<std::string> out;
  for (const std::string& n : flatNames(t)) {
    if (n.rfind("table.", 0) == 0) out.push_back(n);
  }
  return out;
}

std::vector<double> flatValues(const BenchTruth& truth_in) {
  BenchTruth truth = truth_in;
  std::vector<double> values;
  for (const Slot& s : slots(truth)) values.push_back(*s.value);
  for (EffectId id : truth.extra.enabled()) {
    for (double v : truth.extra.flat(id)) values.push_back(v);
  }
  return values;
}

bool setFlatValue(BenchTruth* truth, const std::string& name, double value, std::string* why) {
  for (const Slot& s : slots(*truth)) {
    if (s.name == name) {
      *s.value = value;
      return true;
    }
  }
  if (name.rfind("extra.", 0) == 0) {
    for (EffectId id : kAllEffects) {
      const std::vector<std::string> names = flatParamNames(id);
      for (std::size_t k = 0; k < names.size(); ++k) {
        if ("extra." + names[k] != name) continue;
        // An absent effect starts from its defaults (EffectSet::enable), so that setting one
        // parameter leaves the others valid (angle_harmonic's order >= 1, t_ref_c = 20).
        EffectSet with = truth->extra;
        with.enable(id);
        std::vector<double> v = with.flat(id);
        v[k] = value;
        return truth->extra.setFlat(id, v, why);
      }
    }
  }
  return fail(why, name, "unknown coefficient name");
}

std::optional<double> flatValue(const BenchTruth& truth, const std::string& name) {
  const std::vector<std::string> names = flatNames(truth);
  const std::vector<double> values = flatValues(truth);
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return values[k];
  }
  return std::nullopt;
}

nlohmann::json toJson(const CoefficientReport& report) {
  json j = toJson(report.values);
  BenchTruth truth = report.values;
  std::vector<Slot> all = slots(truth);
  ExtraSlots x = extraSlots(truth.extra);
  all.insert(all.end(), x.slots.begin(), x.slots.end());
  for (const Slot& s : all) {
    const auto u = report.uncertainty.find(s.name);
    if (u == report.uncertainty.end()) continue;
    json& g = groupAt(j, s.group);
    if (u->second.sigma) putShaped(g[kSigmaKey], s, *u->second.sigma, nullptr);
    if (!u->second.observable) putShaped(g[kObservableKey], s, false, true);
  }
  // Arrays in "sigma"/"observable" take the full length of their value arrays.
  auto pad = [](json& group) {
    for (const auto& [sib, fill] : {std::pair<const char*, json>{kSigmaKey, nullptr},
                                    std::pair<const char*, json>{kObservableKey, true}}) {
      const auto it = group.find(sib);
      if (it == group.end()) continue;
      for (auto k = it->begin(); k != it->end(); ++k) {
        const auto v = group.find(k.key());
        if (!k->is_array() || v == group.end() || !v->is_array()) continue;
        while (k->size() < v->size()) k->push_back(fill);
      }
    }
  };
  for (const char* g : {"accel", "gyro", "table"}) pad(j[g]);
  for (auto& [id, e] : j["extra"].items()) pad(e);
  return j;
}

bool fromJson(const nlohmann::json& j, CoefficientReport* report, std::string* why) {
  CoefficientReport r;
  if (!fromJson(j, &r.values, why)) return false;
  BenchTruth truth = r.values;
  std::vector<Slot> all = slots(truth);
  ExtraSlots x = extraSlots(truth.extra);
  all.insert(all.end(), x.slots.begin(), x.slots.end());
  for (const Slot& s : all) {
    const json* g = groupAt(j, s.group);
    if (!g || !g->is_object()) continue;
    const std::string where = s.group + "." + s.key + (s.sub.empty() ? "" : "." + s.sub) +
                              (s.index >= 0 ? "[" + std::to_string(s.index) + "]" : "");
    if (const auto sg = g->find(kSigmaKey); sg != g->end()) {
      if (!sg->is_object())
        return fail(why, s.group + ".sigma", "expected an object, got " + kindText(*sg));
      if (const json* v = getShaped(*sg, s); v && !v->is_null()) {
        double sigma = 0.0;
        if (!readNumber(*v, s.group + ".sigma" + where.substr(s.group.size()), &sigma, why))
          return false;
        if (sigma < 0.0)
          return fail(why, s.group + ".sigma" + where.substr(s.group.size()),
                      "sigma must not be negative");
        r.uncertainty[s.name].sigma = sigma;
      }
    }
    if (const auto ob = g->find(kObservableKey); ob != g->end()) {
      if (!ob->is_object())
        return fail(why, s.group + ".observable", "expected an object, got " + kindText(*ob));
      if (const json* v = getShaped(*ob, s)) {
        if (!v->is_boolean())
          return fail(why, s.group + ".observable" + where.substr(s.group.size()),
                      "expected true or false, got " + kindText(*v));
        if (!v->get<bool>()) r.uncertainty[s.name].observable = false;
      }
    }
  }
  *report = r;
  return true;
}

}  // namespace imubench::calib
