#include "io/import_real.h"

#include <charconv>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace imubench::io {

namespace {

std::string at(const std::string& path, std::size_t line, const std::string& why) {
  return path + ":" + std::to_string(line) + ": " + why;
}

// Splits on any of the separators, skipping empty fields when whitespace-separated.
std::vector<std::string> fields(const std::string& line, char sep) {
  std::vector<std::string> out;
  if (sep == ' ') {
    std::istringstream in(line);
    std::string f;
    while (in >> f) out.push_back(f);
  } else {
    std::string f;
    std::istringstream in(line);
    while (std::getline(in, f, sep)) out.push_back(f);
    if (!line.empty() && line.back() == sep) out.emplace_back();
  }
  return out;
}

bool toDouble(const std::string& s, double* v) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  if (b == e) return false;
  const char* first = s.data() + b;
  if (*first == '+') ++first;
  auto [ptr, ec] = std::from_chars(first, s.data() + e, *v);
  return ec == std::errc() && ptr == s.data() + e;
}

struct Rows {
  std::vector<double> t;
  std::vector<Vec3> v;
};

// Reads a "t x y z" whitespace text file.
bool readTxyz(const std::string& path, Rows* rows, std::string* err) {
  std::ifstream in(path);
  if (!in) {
    *err = path + ": cannot open";
    return false;
  }
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto f = fields(line, ' ');
    if (f.empty()) continue;
    if (f.size() != 4) {
      *err = at(path, n, "expected 4 columns (t x y z), found " + std::to_string(f.size()));
      return false;
    }
    double x[4];
    for (int k = 0; k < 4; ++k)
      if (!toDouble(f[static_cast<std::size_t>(k)], &x[k])) {
        *err = at(path, n,
                  "column " + std::to_string(k + 1) + " '" + f[static_cast<std::size_t>(k)] +
                      "' is not a number");
        return false;
      }
    if (!rows->t.empty() && !(x[0] > rows->t.back())) {
      *err = at(path, n, "time does not increase");
      return false;
    }
    rows->t.push_back(x[0]);
    rows->v.emplace_back(x[1], x[2], x[3]);
  }
  if (rows->t.empty()) {
    *err = path + ": no data rows";
    return false;
  }
  return true;
}

}  // namespace

RealImport readImuTkPair(const std::string& accel_path, const std::string& gyro_path) {
  RealImport r;
  Rows a, g;
  if (!readTxyz(accel_path, &a, &r.error) || !readTxyz(gyro_path, &g, &r.error)) return r;
  if (a.t.size() != g.t.size()) {
    r.error = gyro_path + ": " + std::to_string(g.t.size()) + " rows, but " + accel_path + " has " +
              std::to_string(a.t.size());
    return r;
  }
  for (std::size_t i = 0; i < a.t.size(); ++i)
    if (a.t[i] != g.t[i]) {
      r.error = at(gyro_path, i + 1, "time differs from the accelerometer file's row");
      return r;
    }
  r.data.t = std::move(a.t);
  r.data.accel = std::move(a.v);
  r.data.gyro = std::move(g.v);
  r.accel_unit = "count";
  r.gyro_unit = "count";
  r.ok = true;
  return r;
}

RealImport readImucalCsv(const std::string& path, double rate_hz) {
  RealImport r;
  if (!(rate_hz > 0.0)) {
    r.error = path + ": sampling rate must be > 0";
    return r;
  }
  std::ifstream in(path);
  if (!in) {
    r.error = path + ": cannot open";
    return r;
  }
  std::string line;
  if (!std::getline(in, line)) {
    r.error = path + ":1: empty file";
    return r;
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string> expected = {"n_samples", "gyr_x", "gyr_y", "gyr_z",
                                             "acc_x",     "acc_y", "acc_z"};
  if (fields(line, ',') != expected) {
    r.error = at(path, 1, "header must be n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z");
    return r;
  }
  std::size_t n = 1;
  double last = -1.0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto f = fields(line, ',');
    if (f.size() != 7) {
      r.error = at(path, n, "expected 7 columns, found " + std::to_string(f.size()));
      return r;
    }
    double x[7];
    for (int k = 0; k < 7; ++k)
      if (!toDouble(f[static_cast<std::size_t>(k)], &x[k])) {
        r.error = at(path, n,
                     "column " + expected[static_cast<std::size_t>(k)] + " '" +
                         f[static_cast<std::size_t>(k)] + "' is not a number");
        return r;
      }
    if (!(x[0] > last)) {
      r.error = at(path, n, "n_samples does not increase");
      return r;
    }
    last = x[0];
    r.data.t.push_back(x[0] / rate_hz);
    r.data.gyro.emplace_back(x[1], x[2], x[3]);
    r.data.accel.emplace_back(x[4], x[5], x[6]);
  }
  if (r.data.t.empty()) {
    r.error = path + ": no data rows";
    return r;
  }
  r.accel_unit = "m/s^2";
  r.gyro_unit = "deg/s";
  r.ok = true;
  return r;
}

SectionListImport readImucalSectionList(const std::string& path) {
  SectionListImport r;
  std::ifstream in(path);
  if (!in) {
    r.error = path + ": cannot open";
    return r;
  }
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    r.error = path + ": " + e.what();
    return r;
  }
  if (!j.is_object()) {
    r.error = path + ": expected an object of sections";
    return r;
  }
  for (const auto& [name, v] : j.items()) {
    if (!v.is_object() || !v.contains("start") || !v.contains("end") ||
        !v["start"].is_number_unsigned() || !v["end"].is_number_unsigned()) {
      r.error = path + ": " + name + ": expected {\"start\": n, \"end\": n} with n >= 0";
      return r;
    }
    LabelledRange s{name, v["start"].get<std::size_t>(), v["end"].get<std::size_t>()};
    if (s.end <= s.start) {
      r.error = path + ": " + name + ": end must be after start";
      return r;
    }
    r.sections.push_back(s);
  }
  r.ok = true;
  return r;
}

}  // namespace imubench::io
