#include "io/truth_file.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "io/file_io.h"

namespace imubench::io {
namespace {

long lineOfByte(const std::string& text, size_t byte) {
  byte = std::min(byte, text.size());
  return 1 +
         static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(byte), '\n'));
}

}  // namespace

Status readJsonFile(const std::string& path, nlohmann::json* out) {
  std::string text;
  if (auto st = readWholeFile(path, &text); !st.ok) return st;
  try {
    *out = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const size_t byte = e.byte == 0 ? 0 : e.byte - 1;
    return Status::Error(path + ":" + std::to_string(lineOfByte(text, byte)) +
                         ": JSON syntax error: " + e.what());
  }
  return Status::Ok();
}

Status writeJsonFile(const std::string& path, const nlohmann::json& j) {
  const std::string tmp = path + ".tmp";
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return Status::Error(tmp + ": cannot create: " + std::strerror(errno));
    // nlohmann writes doubles with max_digits10, so every number reads back bit-exactly.
    const std::string text = j.dump(2) + "\n";
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    const bool closed = std::fclose(f) == 0;
    if (!ok || !closed) {
      std::remove(tmp.c_str());
      return Status::Error(tmp + ": write error");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    return Status::Error(path + ": cannot replace: " + ec.message());
  }
  return Status::Ok();
}

TruthFileResult readTruthFile(const std::string& path) {
  return readJsonFileAs<calib::BenchTruth>(path);
}

Status writeTruthFile(const std::string& path, const calib::BenchTruth& truth) {
  return writeJsonFile(path, calib::toJson(truth));
}

CoefficientFileResult readCoefficientFile(const std::string& path) {
  return readJsonFileAs<calib::CoefficientReport>(path);
}

Status writeCoefficientFile(const std::string& path, const calib::CoefficientReport& report) {
  return writeJsonFile(path, calib::toJson(report));
}

}  // namespace imubench::io
