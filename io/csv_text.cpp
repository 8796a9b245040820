#include "io/csv_text.h"

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <system_error>
#include <vector>

namespace imubench::io {

std::string quoteForMessage(std::string_view s) {
  constexpr size_t kMax = 40;
  std::string r = "'";
  r.append(s.substr(0, kMax));
  if (s.size() > kMax) r += "...";
  return r + "'";
}

std::string fmtDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

bool parseNumber(std::string_view field, std::string_view column, double* value, std::string* why) {
  if (field.empty()) {
    *why = "column '" + std::string(column) + "' is empty";
    return false;
  }
  const char* b = field.data();
  const char* e = field.data() + field.size();
  const auto r = std::from_chars(b, e, *value);
  if (r.ec == std::errc::result_out_of_range) {
    *why = "column '" + std::string(column) + "': number out of range " + quoteForMessage(field);
    return false;
  }
  if (r.ec != std::errc() || r.ptr != e) {
    *why = "column '" + std::string(column) + "': not a number " + quoteForMessage(field);
    return false;
  }
  if (!std::isfinite(*value)) {
    *why = "column '" + std::string(column) + "': non-finite value " + quoteForMessage(field);
    return false;
  }
  return true;
}

Status readLineBlocks(const std::string& path,
                      const std::function<bool(std::string_view, size_t)>& block) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return Status::Error(path + ": missing file");
  if (fs::is_directory(path, ec)) return Status::Error(path + ": is a directory, expected a file");
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, Closer> f(std::fopen(path.c_str(), "rb"));
  if (!f) return Status::Error(path + ": cannot open: " + std::strerror(errno));
  const auto size = fs::file_size(path, ec);
  if (ec) return Status::Error(path + ": cannot stat: " + ec.message());
  std::vector<char> buf(kTextBlockBytes);
  size_t filled = 0;  // bytes in buf, the start of an unfinished line first
  for (;;) {
    const size_t n = std::fread(buf.data() + filled, 1, buf.size() - filled, f.get());
    if (n == 0 && std::ferror(f.get())) return Status::Error(path + ": read error");
    filled += n;
    if (n == 0) break;  // end of file
    const void* nl = memrchr(buf.data(), '\n', filled);
    if (!nl) {
      if (filled == buf.size()) buf.resize(2 * buf.size());  // one line longer than the buffer
      continue;
    }
    const size_t whole = static_cast<size_t>(static_cast<const char*>(nl) - buf.data()) + 1;
    if (!block(std::string_view(buf.data(), whole), size)) return Status::Ok();
    std::memmove(buf.data(), buf.data() + whole, filled - whole);
    filled -= whole;
  }
  if (filled > 0) block(std::string_view(buf.data(), filled), size);
  return Status::Ok();
}

}  // namespace imubench::io
