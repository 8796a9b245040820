#include "io/import_real.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
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

// Parses every field of a row as a finite number; on failure names the column (1-based or by
// header name) and whether it is not a number or NaN/infinite.
bool rowValues(const std::vector<std::string>& f, const std::vector<std::string>& names, double* x,
               std::string* why) {
  for (std::size_t k = 0; k < f.size(); ++k) {
    const std::string col = k < names.size() ? names[k] : std::to_string(k + 1);
    if (!toDouble(f[k], &x[k])) {
      *why = "column " + col + " '" + f[k] + "' is not a number";
      return false;
    }
    if (!std::isfinite(x[k])) {
      *why = "column " + col + " is NaN or infinite ('" + f[k] + "')";
      return false;
    }
  }
  return true;
}

// The data rows of a table file from `in` (`line` lines already read), split on `sep` (' ':
// any whitespace; a trailing '\r' dropped), blank lines skipped: each row must hold `columns`
// finite numbers (`names` name them in errors, `shape` follows the column count there) and is
// handed to `row`. False and *err ("path:line: why") at the first bad row, at a row `row`
// refuses (its *why), or when there is no row at all.
bool readRows(std::istream& in, const std::string& path, std::size_t line, char sep,
              std::size_t columns, const std::vector<std::string>& names, std::string_view shape,
              const std::function<bool(const double* x, std::string* why)>& row, std::string* err) {
  std::string text;
  std::vector<double> x(columns);
  bool any = false;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const auto f = fields(text, sep);
    if (f.empty()) continue;
    if (f.size() != columns) {
      *err = at(path, line,
                "expected " + std::to_string(columns) + " columns" + std::string(shape) +
                    ", found " + std::to_string(f.size()) + (in.eof() ? " (truncated?)" : ""));
      return false;
    }
    std::string why;
    if (!rowValues(f, names, x.data(), &why) || !row(x.data(), &why)) {
      *err = at(path, line, why);
      return false;
    }
    any = true;
  }
  if (!any) *err = path + ": no data rows";
  return any;
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
  return readRows(
      in, path, 0, ' ', 4, {}, " (t x y z)",
      [&](const double* x, std::string* why) {
        if (!rows->t.empty() && !(x[0] > rows->t.back())) {
          *why = "time does not increase";
          return false;
        }
        rows->t.push_back(x[0]);
        rows->v.emplace_back(x[1], x[2], x[3]);
        return true;
      },
      err);
}

// Opens a file whose samples are counted at rate_hz (no time column of their own).
bool openAtRate(const std::string& path, double rate_hz, std::ifstream* in, std::string* err) {
  if (!(rate_hz > 0.0)) {
    *err = path + ": sampling rate must be > 0";
    return false;
  }
  in->open(path);
  if (!*in) {
    *err = path + ": cannot open";
    return false;
  }
  return true;
}

}  // namespace

RealImport readImuTkPair(const std::string& accel_path, const std::string& gyro_path) {
  RealImport r;
  Rows a, g;
  if (!readTxyz(accel_path, &a, &r.status.message) || !readTxyz(gyro_path, &g, &r.status.message))
    return r;
  if (a.t.size() != g.t.size()) {
    r.status.message = gyro_path + ": " + std::to_string(g.t.size()) + " rows, but " + accel_path +
                       " has " + std::to_string(a.t.size());
    return r;
  }
  for (std::size_t i = 0; i < a.t.size(); ++i)
    if (a.t[i] != g.t[i]) {
      r.status.message = at(gyro_path, i + 1, "time differs from the accelerometer file's row");
      return r;
    }
  r.data.t = std::move(a.t);
  r.data.accel = std::move(a.v);
  r.data.gyro = std::move(g.v);
  // imu_tk's own files hold 16-bit unsigned counts; the same layout from other loggers often
  // holds signed counts or physical units, where a negative reading is ordinary.
  r.unsigned_counts = true;
  for (std::size_t i = 0; i < r.data.t.size() && r.unsigned_counts; ++i)
    r.unsigned_counts = r.data.accel[i].minCoeff() >= 0.0 && r.data.gyro[i].minCoeff() >= 0.0;
  r.accel_unit = r.unsigned_counts ? "count" : "reading";
  r.gyro_unit = r.unsigned_counts ? "count" : "reading";
  r.status = Status::Ok();
  return r;
}

RealImport readSixColumnLog(const std::string& path, double rate_hz) {
  RealImport r;
  std::ifstream in;
  if (!openAtRate(path, rate_hz, &in, &r.status.message)) return r;
  const std::vector<std::string> names = {"ax", "ay", "az", "wx", "wy", "wz"};
  const bool read = readRows(
      in, path, 0, ' ', names.size(), names, " (ax ay az wx wy wz)",
      [&](const double* x, std::string*) {
        r.data.t.push_back(static_cast<double>(r.data.t.size()) / rate_hz);
        r.data.accel.emplace_back(x[0], x[1], x[2]);
        r.data.gyro.emplace_back(x[3], x[4], x[5]);
        return true;
      },
      &r.status.message);
  if (!read) return r;
  r.accel_unit = "m/s^2";
  r.gyro_unit = "rad/s";
  r.status = Status::Ok();
  return r;
}

RealImport readImucalCsv(const std::string& path, double rate_hz) {
  RealImport r;
  std::ifstream in;
  if (!openAtRate(path, rate_hz, &in, &r.status.message)) return r;
  std::string line;
  if (!std::getline(in, line)) {
    r.status.message = path + ":1: empty file";
    return r;
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string> expected = {"n_samples", "gyr_x", "gyr_y", "gyr_z",
                                             "acc_x",     "acc_y", "acc_z"};
  if (fields(line, ',') != expected) {
    r.status.message = at(path, 1, "header must be n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z");
    return r;
  }
  double last = -1.0;
  const bool read = readRows(
      in, path, 1, ',', expected.size(), expected, "",
      [&](const double* x, std::string* why) {
        if (!(x[0] > last)) {
          *why = "n_samples does not increase";
          return false;
        }
        last = x[0];
        r.data.t.push_back(x[0] / rate_hz);
        r.data.gyro.emplace_back(x[1], x[2], x[3]);
        r.data.accel.emplace_back(x[4], x[5], x[6]);
        return true;
      },
      &r.status.message);
  if (!read) return r;
  r.accel_unit = "m/s^2";
  r.gyro_unit = "deg/s";
  r.status = Status::Ok();
  return r;
}

SectionListImport readImucalSectionList(const std::string& path) {
  SectionListImport r;
  std::ifstream in(path);
  if (!in) {
    r.status.message = path + ": cannot open";
    return r;
  }
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    r.status.message = path + ": " + e.what();
    return r;
  }
  if (!j.is_object()) {
    r.status.message = path + ": expected an object of sections";
    return r;
  }
  for (const auto& [name, v] : j.items()) {
    if (!v.is_object() || !v.contains("start") || !v.contains("end") ||
        !v["start"].is_number_unsigned() || !v["end"].is_number_unsigned()) {
      r.status.message = path + ": " + name + ": expected {\"start\": n, \"end\": n} with n >= 0";
      return r;
    }
    LabelledRange s{name, v["start"].get<std::size_t>(), v["end"].get<std::size_t>()};
    if (s.end <= s.start) {
      r.status.message = path + ": " + name + ": end must be after start";
      return r;
    }
    r.sections.push_back(s);
  }
  r.status = Status::Ok();
  return r;
}

}  // namespace imubench::io
