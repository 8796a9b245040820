#include "io/file_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace imubench::io {
namespace {
struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
}  // namespace

IoStatus readWholeFile(const std::string& path, std::string* out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return IoStatus::Error(path + ": missing file");
  if (fs::is_directory(path, ec))
    return IoStatus::Error(path + ": is a directory, expected a file");
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
  if (!f) return IoStatus::Error(path + ": cannot open: " + std::strerror(errno));
  const auto size = fs::file_size(path, ec);
  if (ec) return IoStatus::Error(path + ": cannot stat: " + ec.message());
  out->resize(size);
  if (size > 0 && std::fread(out->data(), 1, size, f.get()) != size) {
    return IoStatus::Error(path + ": read error");
  }
  return IoStatus::Ok();
}

}  // namespace imubench::io
