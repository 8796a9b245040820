#include "io/format_hint.h"

#include <filesystem>
#include <fstream>
#include <string_view>
#include <vector>

#include "io/csv_text.h"

namespace imubench::io {
namespace {

std::vector<std::string> split(const std::string& line, char delim) {
  std::vector<std::string> out;
  std::string f;
  for (char c : line) {
    const bool sep = delim == ' ' ? (c == ' ' || c == '\t') : c == delim;
    if (!sep) {
      if (c != '\r' && c != '"') f += c;
      continue;
    }
    if (delim != ' ' || !f.empty()) out.push_back(f);
    f.clear();
  }
  if (!f.empty() || (delim != ' ' && !line.empty())) out.push_back(f);
  return out;
}

bool allNumbers(const std::vector<std::string>& f) {
  for (const std::string& x : f) {
    double v = 0.0;
    std::string why;
    if (!parseNumber(x, "", &v, &why)) return false;
  }
  return !f.empty();
}

std::string importHint(const std::string& path, const std::vector<std::string>& names) {
  std::string cols;
  for (const std::string& n : names) cols += (cols.empty() ? "" : ", ") + n;
  return "; a logger's file: imubench import-csv " + path +
         " --columns t=COL,wx=COL,wy=COL,wz=COL,ax=COL,ay=COL,az=COL --units "
         "t=s,w=deg/s,a=g --out DIR (columns by header name or 1-based index" +
         (cols.empty() ? std::string(")") : "; this file's: " + cols + ")") +
         ", then imubench calibrate DIR";
}

}  // namespace

std::string recordingFileHint(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return "";
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line) && (line.empty() || line == "\r" || line[0] == '#')) {
  }
  if (line.empty()) return "";
  if (line.rfind("n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z", 0) == 0)
    return "; it looks like imucal's Ferraris CSV: add --format imucal";
  const std::vector<std::string> ws = split(line, ' ');
  if (allNumbers(ws) && ws.size() == 4)
    return "; it looks like an imu_tk text file (t x y z): add --format imutk --gyro GYRO_FILE";
  if (allNumbers(ws) && ws.size() == 6)
    return "; it looks like an imu-calib log (ax ay az wx wy wz, SI, 100 Hz): add --format "
           "imu-calib";
  for (char d : {',', ';', '\t'}) {
    const std::vector<std::string> f = split(line, d);
    if (f.size() >= 2) return importHint(path, allNumbers(f) ? std::vector<std::string>{} : f);
  }
  return importHint(path, {});
}

}  // namespace imubench::io
