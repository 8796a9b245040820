#include "daemon/plan_library.h"

#include <algorithm>
#include <filesystem>
#include <utility>

#include "io/file_io.h"

namespace imubench::daemon {
namespace {

namespace fs = std::filesystem;

// The advice every refused path gets: what the client should do instead.
constexpr const char* kSendText =
    "send the plan's text instead ({\"plan\":{\"toml\":...,\"name\":...}}; `imubench start` "
    "and the Python client read the file with your rights and do this)";

// Whether p lies inside dir (both absolute and normalized), lexically.
bool inside(const fs::path& p, const fs::path& dir) {
  const fs::path rel = p.lexically_relative(dir);
  if (rel.empty() || rel == ".") return false;
  return *rel.begin() != "..";
}

}  // namespace

std::optional<std::string> refuseLibraryPath(const std::string& path, const std::string& plan_dir) {
  if (plan_dir.empty())
    return path + ": this bench has no plan library (plan_dir), the daemon reads no plan " +
           "files for clients; " + kSendText;
  const fs::path p = fs::path(path).lexically_normal();
  fs::path dir = fs::path(plan_dir).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();  // a trailing slash: the directory itself
  if (!p.is_absolute() || !dir.is_absolute() || !inside(p, dir))
    return path + ": not in this bench's plan library (" + plan_dir +
           "); the daemon reads no other files for clients; " + kSendText;
  return std::nullopt;
}

PlanFile readLibraryFile(const std::string& path, const PlanLibraryOptions& options) {
  if (auto why = refuseLibraryPath(path, options.plan_dir)) {
    PlanFile f;
    f.status = Status::Error(*why);
    return f;
  }
  // The file actually opened (symlinks resolved) must be inside the library too.
  auto resolves_inside = [&options](int fd) -> std::string {
    std::error_code ec_file;
    std::error_code ec_dir;
    const fs::path real = fs::read_symlink("/proc/self/fd/" + std::to_string(fd), ec_file);
    const fs::path real_dir = fs::canonical(options.plan_dir, ec_dir);
    if (ec_file || ec_dir || !inside(real, real_dir))
      return "resolves outside this bench's plan library (" + options.plan_dir + ")";
    return {};
  };
  io::UserFile read = io::readUserFile(path, options.max_bytes, "a plan may have", resolves_inside);
  PlanFile f;
  f.status = read.ok() ? Status::Ok() : Status::Error(std::move(read.message));
  f.text = std::move(read.text);
  return f;
}

std::vector<std::string> listLibraryFiles(const std::string& plan_dir) {
  std::vector<std::string> files;
  if (plan_dir.empty()) return files;
  std::error_code ec;
  for (fs::directory_iterator it(plan_dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (it->path().extension() == ".toml" && it->is_regular_file(type_ec))
      files.push_back(it->path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

PlanLibrary::PlanLibrary(EventLoop* loop, PlanLibraryOptions options)
    : options_(std::move(options)), jobs_(loop, options_.max_pending) {}

bool PlanLibrary::read(const std::string& path, std::function<void(PlanFile)> done,
                       std::string* why) {
  auto job = [path, options = options_, done]() -> std::function<void()> {
    PlanFile file = readLibraryFile(path, options);
    return [done, file = std::move(file)] { done(file); };
  };
  auto failed = [path, done](const std::string& what) {
    PlanFile file;
    file.status = Status::Error(path + ": " + what);
    done(file);
  };
  if (jobs_.run(job, failed, why)) return true;
  *why = path + ": " + *why;
  return false;
}

bool PlanLibrary::list(std::function<void(std::vector<std::string>)> done, std::string* why) {
  auto job = [dir = options_.plan_dir, done]() -> std::function<void()> {
    std::vector<std::string> files = listLibraryFiles(dir);
    return [done, files = std::move(files)] { done(files); };
  };
  return jobs_.run(
      job, [done](const std::string&) { done({}); }, why);
}

}  // namespace imubench::daemon
