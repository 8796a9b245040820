#include "io/thermal_file.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "io/truth_file.h"

namespace imubench::io {
namespace {

namespace m = calib::model;
constexpr const char* kAxes[3] = {"x", "y", "z"};

nlohmann::json polyJson(const m::ThermalCoefficient& c) {
  nlohmann::json j;
  j["poly"] = nlohmann::json::array();
  nlohmann::json sp = nlohmann::json::array();
  bool any_sigma = c.sigma_dTdt != 0.0;
  for (int k = 0; k <= c.order; ++k) {
    j["poly"].push_back(c.poly[static_cast<std::size_t>(k)]);
    sp.push_back(c.sigma_poly[static_cast<std::size_t>(k)]);
    any_sigma = any_sigma || c.sigma_poly[static_cast<std::size_t>(k)] != 0.0;
  }
  if (c.hysteresis) j["dTdt"] = c.dTdt;
  if (any_sigma) {
    j["sigma"]["poly"] = sp;
    if (c.hysteresis) j["sigma"]["dTdt"] = c.sigma_dTdt;
  }
  return j;
}

// Reads a number array of 1..kMaxThermalOrder+1 entries.
bool readPoly(const nlohmann::json& j, const std::string& path, double* out, int* n,
              std::string* why) {
  if (!j.is_array() || j.empty() || j.size() > m::kMaxThermalOrder + 1) {
    *why =
        path + ": expected an array of 1.." + std::to_string(m::kMaxThermalOrder + 1) + " numbers";
    return false;
  }
  for (std::size_t k = 0; k < j.size(); ++k) {
    if (!j[k].is_number() || !std::isfinite(j[k].get<double>())) {
      *why = path + "[" + std::to_string(k) + "]: expected a finite number";
      return false;
    }
    out[k] = j[k].get<double>();
  }
  *n = static_cast<int>(j.size());
  return true;
}

bool readNumber(const nlohmann::json& j, const std::string& path, double* out, std::string* why) {
  if (!j.is_number() || !std::isfinite(j.get<double>())) {
    *why = path + ": expected a finite number";
    return false;
  }
  *out = j.get<double>();
  return true;
}

bool coefficientFromJson(const nlohmann::json& j, const std::string& path, m::ThermalCoefficient* c,
                         std::string* why) {
  *c = {};
  if (!j.is_object() || !j.contains("poly")) {
    *why = path + ": expected {\"poly\": [..], \"dTdt\": h, \"sigma\": {..}}";
    return false;
  }
  int n = 0;
  if (!readPoly(j["poly"], path + ".poly", c->poly.data(), &n, why)) return false;
  c->order = n - 1;
  if (j.contains("dTdt")) {
    if (!readNumber(j["dTdt"], path + ".dTdt", &c->dTdt, why)) return false;
    c->hysteresis = true;
  }
  if (!j.contains("sigma")) return true;
  const nlohmann::json& s = j["sigma"];
  if (!s.is_object()) {
    *why = path + ".sigma: expected an object";
    return false;
  }
  if (s.contains("poly")) {
    int ns = 0;
    if (!readPoly(s["poly"], path + ".sigma.poly", c->sigma_poly.data(), &ns, why)) return false;
    if (ns != n) {
      *why =
          path + ".sigma.poly: " + std::to_string(ns) + " entries, poly has " + std::to_string(n);
      return false;
    }
  }
  if (s.contains("dTdt") && !readNumber(s["dTdt"], path + ".sigma.dTdt", &c->sigma_dTdt, why)) {
    return false;
  }
  return true;
}

// JSON key path of block entry i within a triad object: {"scale", 0}, {"misalignment", "xy"}.
std::string keyOf(int i) {
  return i < m::kBias ? "scale" : i < m::kMis ? "bias" : "misalignment";
}
std::string subkeyOf(int i) {
  return i < m::kMis ? kAxes[i % 3] : m::kMisEntries[static_cast<std::size_t>(i - m::kMis)].name;
}

nlohmann::json triadJson(const m::ThermalTriad& t) {
  nlohmann::json j;
  for (int i = 0; i < m::kTriadSize; ++i) {
    const nlohmann::json p = polyJson(t[static_cast<std::size_t>(i)]);
    if (i < m::kMis) {
      j[keyOf(i)].push_back(p);
    } else {
      j["misalignment"][subkeyOf(i)] = p;
    }
  }
  return j;
}

bool triadFromJson(const nlohmann::json& j, const std::string& name, m::ThermalTriad* t,
                   std::string* why) {
  if (!j.is_object()) {
    *why = name + ": expected an object with scale, bias, misalignment";
    return false;
  }
  for (int i = 0; i < m::kTriadSize; ++i) {
    const std::string key = keyOf(i);
    if (!j.contains(key)) {
      *why = name + "." + key + ": missing";
      return false;
    }
    const nlohmann::json& k = j[key];
    const nlohmann::json* p = nullptr;
    std::string path = name + "." + key;
    if (i < m::kMis) {
      if (!k.is_array() || k.size() != 3) {
        *why = path + ": expected an array of 3 coefficients";
        return false;
      }
      p = &k[static_cast<std::size_t>(i % 3)];
      path += "[" + std::to_string(i % 3) + "]";
    } else {
      path += "." + subkeyOf(i);
      if (!k.is_object() || !k.contains(subkeyOf(i))) {
        *why = path + ": missing";
        return false;
      }
      p = &k[subkeyOf(i)];
    }
    if (!coefficientFromJson(*p, path, &(*t)[static_cast<std::size_t>(i)], why)) return false;
  }
  return true;
}

}  // namespace

nlohmann::json toJson(const ThermalFile& file) {
  const m::ThermalCoefficients& c = file.coefficients;
  nlohmann::json j;
  j["format"] = kThermalFormat;
  j["imu"]["serial"] = file.imu_serial;
  j["t_ref_c"] = c.t_ref_c;
  j["range_c"] = {c.t_min_c, c.t_max_c};
  j["accel"] = triadJson(c.accel);
  j["gyro"] = triadJson(c.gyro);
  return j;
}

bool fromJson(const nlohmann::json& j, ThermalFile* file, std::string* why) {
  *file = {};
  if (!j.is_object() || !j.contains("format") || j["format"] != kThermalFormat) {
    *why = std::string("format: expected \"") + kThermalFormat + "\"";
    return false;
  }
  if (j.contains("imu")) {
    if (!j["imu"].is_object() || (j["imu"].contains("serial") && !j["imu"]["serial"].is_string())) {
      *why = "imu.serial: expected a string";
      return false;
    }
    file->imu_serial = j["imu"].value("serial", "");
  }
  m::ThermalCoefficients& c = file->coefficients;
  if (!j.contains("t_ref_c") || !readNumber(j["t_ref_c"], "t_ref_c", &c.t_ref_c, why)) {
    if (why->empty()) *why = "t_ref_c: missing";
    return false;
  }
  const nlohmann::json r = j.value("range_c", nlohmann::json());
  if (!r.is_array() || r.size() != 2 || !readNumber(r[0], "range_c[0]", &c.t_min_c, why) ||
      !readNumber(r[1], "range_c[1]", &c.t_max_c, why) || !(c.t_min_c <= c.t_max_c)) {
    *why = "range_c: expected [tmin, tmax] with tmin <= tmax";
    return false;
  }
  for (const char* t : {"accel", "gyro"}) {
    if (!j.contains(t)) {
      *why = std::string(t) + ": missing";
      return false;
    }
  }
  return triadFromJson(j["accel"], "accel", &c.accel, why) &&
         triadFromJson(j["gyro"], "gyro", &c.gyro, why);
}

ThermalFileResult readThermalFile(const std::string& path) {
  return readJsonFileAs<ThermalFile>(path);
}

Status writeThermalFile(const std::string& path, const ThermalFile& file) {
  return writeJsonFile(path, toJson(file));
}

Status writeThermalCsv(const std::string& path, const ThermalFile& file) {
  std::ostringstream os;
  os.precision(17);
  os << "triad,coefficient,axis,c0,c1,c2,c3,c4,dTdt,tmin,tmax\n";
  const m::ThermalCoefficients& c = file.coefficients;
  for (const bool accel : {true, false}) {
    for (int i = 0; i < m::kTriadSize; ++i) {
      const m::ThermalCoefficient& k = (accel ? c.accel : c.gyro)[static_cast<std::size_t>(i)];
      os << (accel ? "accel" : "gyro") << ',' << keyOf(i) << ',' << subkeyOf(i);
      for (int n = 0; n <= m::kMaxThermalOrder; ++n) {
        os << ',';
        if (n <= k.order) os << k.poly[static_cast<std::size_t>(n)];
      }
      os << ',';
      if (k.hysteresis) os << k.dTdt;
      os << ',' << c.t_min_c << ',' << c.t_max_c << '\n';
    }
  }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return Status::Error(path + ": cannot create");
  const std::string text = os.str();
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) return Status::Error(path + ": write failed");
  return Status::Ok();
}

}  // namespace imubench::io
