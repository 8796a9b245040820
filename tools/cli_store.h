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
//
// Two programs share this interface. `imubench` links no SQLite: its store backend
// (cli_store_exec.cpp) throws NeedsRunStore, and main() then runs `imubench-store` (installed
// next to it) with the same arguments, so the store commands behave as documented.
// `imubench-store` is the same command line linked with the SQLite backend
// (cli_store_sqlite.cpp, daemon/store.h).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/recording.h"
#include "tools/cli11.h"

namespace imubench::tools {

inline constexpr const char* kDefaultStorePath = "/var/lib/imubench/imubench.db";
inline constexpr const char* kStorePathEnv = "IMUBENCH_DB";

// $IMUBENCH_DB when set and non-empty, else kDefaultStorePath.
std::string defaultStorePath();

// Adds `--db PATH` to `sub`, bound to *db_path (set to defaultStorePath() here). PATH may also
// be the lab database's URI, postgresql://ROLE@HOST:PORT/DB (issue 30; password from libpq's
// PGPASSFILE or ~/.pgpass) for the commands that read: runs, results.
void addStoreOption(CLI::App& sub, std::string* db_path);

// "N" or "run:N" with N a positive integer (decimal digits only, no sign, no spaces).
std::optional<std::int64_t> parseRunId(const std::string& text);

struct ResolvedRecording {
  io::Recording recording;
  std::optional<std::int64_t> run_id;  // set when read from the store
  std::string label;                   // for messages: the directory, or "run N"
};

// Resolves a RUN_OR_DIR argument (see the top of this file); throws CommandFailed on failure
// (the recording reader's or the store's message, or "'x' is neither a recording directory
// nor a run id").
ResolvedRecording loadRunOrDir(const std::string& arg, const std::string& db_path);

// ---- The store backend (cli_store_sqlite.cpp in imubench-store, cli_store_exec.cpp in
// imubench) ----

// Thrown by imubench's backend when a command needs the run store; main() then hands the
// whole command line to imubench-store (runStoreProgram).
class NeedsRunStore : public std::runtime_error {
 public:
  NeedsRunStore() : std::runtime_error("this command needs the run store (imubench-store)") {}
};

// Runs imubench-store with argv (argv[0] kept). Returns only on failure, with the reason.
std::string runStoreProgram(char** argv);

// Run `id` of the store at db_path as a recording; throws CommandFailed with the store's
// message.
io::Recording loadStoredRun(std::int64_t id, const std::string& db_path);

// Stores `json` as a result of `kind` of run `run_id`; returns its result id or throws
// CommandFailed.
std::int64_t storeRunResult(const std::string& db_path, std::int64_t run_id,
                            const std::string& imu_serial, double temperature_c,
                            const std::string& kind, const std::string& json);

// Stored results (daemon/store.h StoredResult) of one run or of one IMU serial, by id.
struct StoredResultRow {
  std::string bench;  // the bench that stored it: set when read from the lab database
  std::int64_t id = 0;
  std::int64_t run_id = 0;
  std::string imu_serial;
  double temperature_c = 0.0;
  std::string kind;
  std::string json;
  double created_unix_s = 0.0;
};
// db_path may be the lab database (`postgresql://...`, issue 30): then the rows of every bench
// (or of `bench`), each naming its bench. A run id names one run only together with its bench.
std::vector<StoredResultRow> loadStoredResults(const std::string& db_path,
                                               std::optional<std::int64_t> run_id,
                                               std::optional<std::string> imu_serial,
                                               std::optional<std::string> bench = std::nullopt);

// A run's state as stored, and where it stopped (its step events): what `results RUN` says
// when a run has no results, e.g. after a crash.
struct StoredRunState {
  std::string plan_name;
  std::string plan_toml;  // the plan's text as the run started it
  std::string bench_name;
  std::string imu_serial;
  double started_unix_s = 0.0;
  std::optional<double> finished_unix_s;  // absent while running and for interrupted runs
  std::string state;                      // daemon/store.h runStateName: running, interrupted, ...
  std::string exit_reason;                // empty while running
  std::optional<int> step;                // the last step started (0-based); absent: none started
  std::string step_label;
  int last_finished_step = -1;  // -1: none finished
};
StoredRunState loadRunState(const std::string& db_path, std::int64_t run_id);

// The store subcommands' work (registered by addStoreCommands in cli_runs.cpp).
struct RunsOptions {
  std::string db;
  bool json = false;
};
struct ExportOptions {
  std::string run;
  std::string db;
  std::string csv_dir;
  std::string results;
};
struct ImportOptions {
  std::string dir;
  std::string db;
  std::string plan_name;
  std::optional<std::string> serial;
};
void runRuns(const RunsOptions& o);
void runExport(const ExportOptions& o);
void runImport(const ImportOptions& o);

}  // namespace imubench::tools
