#include "io/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

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

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

UserFile refused(UserFileError e, const std::string& path, const std::string& why) {
  UserFile f;
  f.error = e;
  f.message = path + ": " + why;
  return f;
}

std::string tooLarge(std::size_t max_bytes, const std::string& limit_name) {
  return "more than the " + std::to_string(max_bytes) + " bytes " + limit_name;
}

// The whole of an open regular file, at most max_bytes (it may grow meanwhile).
UserFile readOpen(int fd, const std::string& path, std::size_t max_bytes,
                  const std::string& limit_name) {
  UserFile f;
  char buf[64 * 1024];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n == 0) break;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      return refused(UserFileError::kRead, path, std::string("read: ") + std::strerror(errno));
    f.text.append(buf, static_cast<std::size_t>(n));
    if (f.text.size() > max_bytes)
      return refused(UserFileError::kTooLarge, path,
                     "longer than the " + std::to_string(max_bytes) + " bytes " + limit_name);
  }
  return f;
}
}  // namespace

UserFile readUserFile(const std::string& path, std::size_t max_bytes, const std::string& limit_name,
                      const std::function<std::string(int fd)>& vet) {
  Fd file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY)};
  if (file.fd < 0) {
    if (errno == ENOENT) return refused(UserFileError::kMissing, path, "no such file");
    if (errno == EWOULDBLOCK)
      return refused(UserFileError::kBusy, path,
                     "held by another process (lease); try again later");
    return refused(UserFileError::kOpen, path, std::string("cannot open: ") + std::strerror(errno));
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0)
    return refused(UserFileError::kOpen, path, std::string("fstat: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) return refused(UserFileError::kNotRegular, path, "not a regular file");
  if (static_cast<std::size_t>(st.st_size) > max_bytes)
    return refused(UserFileError::kTooLarge, path,
                   std::to_string(st.st_size) + " bytes, " + tooLarge(max_bytes, limit_name));
  if (vet) {
    if (std::string why = vet(file.fd); !why.empty())
      return refused(UserFileError::kVetoed, path, why);
  }
  return readOpen(file.fd, path, max_bytes, limit_name);
}

Status readWholeFile(const std::string& path, std::string* out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return Status::Error(path + ": missing file");
  if (fs::is_directory(path, ec)) return Status::Error(path + ": is a directory, expected a file");
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
  if (!f) return Status::Error(path + ": cannot open: " + std::strerror(errno));
  const auto size = fs::file_size(path, ec);
  if (ec) return Status::Error(path + ": cannot stat: " + ec.message());
  out->resize(size);
  if (size > 0 && std::fread(out->data(), 1, size, f.get()) != size) {
    return Status::Error(path + ": read error");
  }
  return Status::Ok();
}

}  // namespace imubench::io
