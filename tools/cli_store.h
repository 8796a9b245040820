// The run store on the command line: the --db option and the RUN_OR_DIR argument that lets a
// command read a recording either from an imubench-csv/1 directory or from a run in the
// daemon's SQLite store (daemon/store.h).
//
//   --db PATH   the store; default $IMUBENCH_DB when set and non-empty, else kDefaultStorePath.
//   RUN_OR_DIR  an existing directory is read as a recording; otherwise "N" or "run:N" (N a
//               positive integer) is run N of the store; anything else is refused, naming both
//               interpretations. A directory wins over a run id of the same spelling.
//
// Commands that only read (export, runs, calibrate on a run id) refuse a store file that does
// not exist instead of creating an empty database; import creates it.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "daemon/recording.h"
#include "daemon/store.h"
#include "tools/cli11.h"

namespace imubench::tools {

inline constexpr const char* kDefaultStorePath = "/var/lib/imubench/imubench.db";
inline constexpr const char* kStorePathEnv = "IMUBENCH_DB";

// $IMUBENCH_DB when set and non-empty, else kDefaultStorePath.
std::string defaultStorePath();

// Adds `--db PATH` to `sub`, bound to *db_path (set to defaultStorePath() here).
void addStoreOption(CLI::App& sub, std::string* db_path);

// "N" or "run:N" with N a positive integer (decimal digits only, no sign, no spaces).
std::optional<std::int64_t> parseRunId(const std::string& text);

enum class StoreAccess {
  kExisting,  // the file must exist (reading commands do not create a database)
  kCreate,    // created with its schema when missing (import)
};
// Opens the store or throws CommandFailed with the store's message.
std::unique_ptr<daemon::Store> openStoreOrFail(const std::string& db_path, StoreAccess access);

struct ResolvedRecording {
  daemon::Recording recording;
  std::optional<std::int64_t> run_id;  // set when read from the store
  std::string label;                   // for messages: the directory, or "run N"
};

// Resolves a RUN_OR_DIR argument (see the top of this file); throws CommandFailed on failure
// (the recording reader's or the store's message, or "'x' is neither a recording directory
// nor a run id").
ResolvedRecording loadRunOrDir(const std::string& arg, const std::string& db_path);

}  // namespace imubench::tools
