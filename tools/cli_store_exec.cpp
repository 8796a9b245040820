// The store backend of `imubench` (tools/cli_store.h): no SQLite here. Every store operation
// throws NeedsRunStore before any output; main() then runs imubench-store, the same command
// line linked with the SQLite backend, with the same arguments (runStoreProgram).
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

// The store program's file name, looked up next to the running imubench (build tree and
// install prefix alike put both in one directory).
constexpr const char* kStoreProgram = "imubench-store";

}  // namespace

std::string runStoreProgram(char** argv) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return std::string("cannot find the imubench executable: ") + ec.message();
  const std::string program = (self.parent_path() / kStoreProgram).string();
  ::execv(program.c_str(), argv);
  return "cannot run the run store program " + program + ": " + std::strerror(errno);
}

io::Recording loadStoredRun(std::int64_t /*id*/, const std::string& /*db_path*/) {
  throw NeedsRunStore();
}

std::int64_t storeRunResult(const std::string& /*db_path*/, std::int64_t /*run_id*/,
                            const std::string& /*imu_serial*/, double /*temperature_c*/,
                            const std::string& /*kind*/, const std::string& /*json*/) {
  throw NeedsRunStore();
}

std::vector<StoredResultRow> loadStoredResults(const std::string& /*db_path*/,
                                               std::optional<std::int64_t> /*run_id*/,
                                               std::optional<std::string> /*imu_serial*/,
                                               std::optional<std::string> /*bench*/) {
  throw NeedsRunStore();
}

StoredRunState loadRunState(const std::string& /*db_path*/, std::int64_t /*run_id*/) {
  throw NeedsRunStore();
}

void runRuns(const RunsOptions& /*o*/) {
  throw NeedsRunStore();
}
void runExport(const ExportOptions& /*o*/) {
  throw NeedsRunStore();
}
void runImport(const ImportOptions& /*o*/) {
  throw NeedsRunStore();
}

}  // namespace imubench::tools
