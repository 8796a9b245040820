#include "tools/cli_store.h"

#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <string_view>
#include <system_error>

#include "io/format_hint.h"
#include "tools/cli_common.h"

namespace imubench::tools {

std::string defaultStorePath() {
  const char* env = std::getenv(kStorePathEnv);
  if (env != nullptr && *env != '\0') return env;
  return kDefaultStorePath;
}

void addStoreOption(CLI::App& sub, std::string* db_path) {
  *db_path = defaultStorePath();
  sub.add_option(
         "--db", *db_path,
         std::string("run store (SQLite); default $") + kStorePathEnv + " or " + kDefaultStorePath)
      ->capture_default_str();
}

std::optional<std::int64_t> parseRunId(const std::string& text) {
  std::string_view digits(text);
  if (digits.starts_with("run:")) digits.remove_prefix(4);
  if (digits.empty()) return std::nullopt;
  for (const char c : digits) {
    if (c < '0' || c > '9') return std::nullopt;
  }
  std::int64_t id = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), id);
  if (ec != std::errc() || end != digits.data() + digits.size() || id <= 0) return std::nullopt;
  return id;
}

ResolvedRecording loadRunOrDir(const std::string& arg, const std::string& db_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  ResolvedRecording out;
  if (fs::is_directory(arg, ec)) {
    io::RecordingReadResult r = io::readRecording(arg);
    if (!r.status.ok) throw CommandFailed(r.status.message);
    out.recording = std::move(r.value);
    out.label = arg;
    return out;
  }
  if (const std::optional<std::int64_t> id = parseRunId(arg)) {
    out.recording = loadStoredRun(*id, db_path);
    out.run_id = *id;
    out.label = "run " + std::to_string(*id);
    return out;
  }
  const bool exists = fs::exists(arg, ec);
  throw CommandFailed("'" + arg + "' is neither a recording directory (" +
                      (exists ? "not a directory" : "no such directory") +
                      ") nor a run id (N or run:N, N >= 1)" + io::recordingFileHint(arg));
}

}  // namespace imubench::tools
