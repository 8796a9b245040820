// The run store's subcommands (tools/cli_store.h for --db and run ids):
//
// imubench runs [--db PATH] [--json]
//   Lists the stored runs: id, state, start time (UTC), plan, IMU serial, exit reason.
// imubench export RUN --csv DIR [--results FILE.json] [--db PATH]
//   Writes run RUN (N or run:N) as an imubench-csv/1 recording directory; the store keeps the
//   doubles bit-exactly, so an imported recording exports to the same files. --results writes
//   the run's stored results (calibration coefficients, reports) as a JSON array.
// imubench import DIR [--plan-name NAME] [--serial S] [--db PATH]
//   Stores an imubench-csv/1 recording directory as a finished run (exit reason "imported")
//   and prints the new run id alone on stdout, for scripts: run=$(imubench import DIR).
//   --serial replaces the recording's IMU serial in the store.
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "daemon/recording.h"
#include "daemon/store.h"
#include "daemon/truth_file.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

const char* tableKindName(calib::TableKind kind) {
  return kind == calib::TableKind::kThreeAxis ? "three-axis" : "two-axis";
}

// "2024-05-01T12:00:00Z"; "-" for a time that does not fit.
std::string utcTime(double unix_s) {
  if (!std::isfinite(unix_s)) return "-";
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  if (gmtime_r(&t, &tm) == nullptr) return "-";
  char buf[32];
  if (std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm) == 0) return "-";
  return buf;
}

std::string orDash(const std::string& s) {
  return s.empty() ? "-" : s;
}

// ---- runs ----

struct RunsOptions {
  std::string db;
  bool json = false;
};

nlohmann::json runJson(const daemon::RunInfo& r) {
  nlohmann::json j = {{"id", r.id},
                      {"state", daemon::runStateName(r.state)},
                      {"plan_name", r.start.plan_name},
                      {"bench_name", r.start.bench_name},
                      {"imu_serial", r.start.imu_serial},
                      {"imu_rate_hz", r.start.imu_rate_hz},
                      {"table_kind", tableKindName(r.start.table_kind)},
                      {"started_unix_s", r.started_unix_s},
                      {"finished_unix_s", nullptr},
                      {"exit_reason", r.exit_reason}};
  if (r.finished_unix_s) j["finished_unix_s"] = *r.finished_unix_s;
  return j;
}

void runRuns(const RunsOptions& o) {
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kExisting);
  const daemon::RunListResult list = store->listRuns();
  if (!list.status.ok) throw CommandFailed(list.status.message);
  if (o.json) {
    nlohmann::json a = nlohmann::json::array();
    for (const daemon::RunInfo& r : list.runs) a.push_back(runJson(r));
    std::cout << a.dump(2) << "\n";
    return;
  }
  if (list.runs.empty()) {
    std::cout << "no runs in " << o.db << "\n";
    return;
  }
  std::printf("%6s  %-11s  %-20s  %-24s  %-16s  %s\n", "id", "state", "started (UTC)", "plan",
              "IMU serial", "exit reason");
  for (const daemon::RunInfo& r : list.runs) {
    std::printf("%6lld  %-11s  %-20s  %-24s  %-16s  %s\n", static_cast<long long>(r.id),
                daemon::runStateName(r.state), utcTime(r.started_unix_s).c_str(),
                orDash(r.start.plan_name).c_str(), orDash(r.start.imu_serial).c_str(),
                orDash(r.exit_reason).c_str());
  }
}

// ---- export ----

struct ExportOptions {
  std::string run;
  std::string db;
  std::string csv_dir;
  std::string results;
};

void runExport(const ExportOptions& o) {
  const std::optional<std::int64_t> id = parseRunId(o.run);
  if (!id) throw CommandFailed("'" + o.run + "' is not a run id (N or run:N, N >= 1)", 2);
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kExisting);
  const daemon::RecordingReadResult rec = store->loadRecording(*id);
  if (!rec.status.ok) throw CommandFailed(rec.status.message);
  if (const daemon::IoStatus s = daemon::writeRecording(o.csv_dir, rec.recording); !s.ok) {
    throw CommandFailed(s.message);
  }
  std::cout << "run " << *id << " written to " << o.csv_dir << " (" << daemon::kRecordingFormat
            << ", " << rec.recording.imu.size() << " IMU samples)\n";
  if (o.results.empty()) return;
  daemon::ResultFilter filter;
  filter.run_id = *id;
  const daemon::ResultListResult results = store->results(filter);
  if (!results.status.ok) throw CommandFailed(results.status.message);
  nlohmann::json a = nlohmann::json::array();
  for (const daemon::StoredResult& r : results.results) {
    nlohmann::json value = nlohmann::json::parse(r.json, nullptr, false);
    if (value.is_discarded()) value = r.json;  // the store checks JSON on insert; keep the text
    a.push_back({{"id", r.id},
                 {"run_id", r.run_id},
                 {"imu_serial", r.imu_serial},
                 {"temperature_c", r.temperature_c},
                 {"kind", r.kind},
                 {"created_unix_s", r.created_unix_s},
                 {"json", value}});
  }
  if (const daemon::IoStatus s = daemon::writeJsonFile(o.results, a); !s.ok) {
    throw CommandFailed(s.message);
  }
  std::cout << results.results.size() << " result(s) of run " << *id << " written to " << o.results
            << "\n";
}

// ---- import ----

struct ImportOptions {
  std::string dir;
  std::string db;
  std::string plan_name;
  std::optional<std::string> serial;
};

void runImport(const ImportOptions& o) {
  const daemon::RecordingReadResult rec = daemon::readRecording(o.dir);
  if (!rec.status.ok) throw CommandFailed(rec.status.message);
  daemon::RunStart start = daemon::runStartFromRecording(rec.recording);
  start.plan_name = o.plan_name;
  if (o.serial) start.imu_serial = *o.serial;
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kCreate);
  const daemon::RunIdResult r = store->importRecording(start, rec.recording);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  std::cerr << "imported " << o.dir << " into " << o.db << " as run " << r.run_id << "\n";
  std::cout << r.run_id << "\n";
}

}  // namespace

void addStoreCommands(CLI::App& app) {
  {
    auto opt = std::make_shared<RunsOptions>();
    CLI::App* sub = app.add_subcommand("runs", "List the runs in the run store");
    addStoreOption(*sub, &opt->db);
    sub->add_flag("--json", opt->json, "Print the runs as a JSON array");
    sub->callback([opt] { runRuns(*opt); });
  }
  {
    auto opt = std::make_shared<ExportOptions>();
    CLI::App* sub =
        app.add_subcommand("export", "Write a stored run as an imubench-csv/1 recording");
    sub->add_option("run", opt->run, "Run id: N or run:N")->required();
    sub->add_option("--csv", opt->csv_dir, "Recording directory to write (created if missing)")
        ->required();
    sub->add_option("--results", opt->results,
                    "Also write the run's stored results to this JSON file");
    addStoreOption(*sub, &opt->db);
    sub->callback([opt] { runExport(*opt); });
  }
  {
    auto opt = std::make_shared<ImportOptions>();
    CLI::App* sub = app.add_subcommand(
        "import", "Store an imubench-csv/1 recording as a finished run; prints the run id");
    sub->add_option("dir", opt->dir, "Recording directory (imubench-csv/1)")->required();
    sub->add_option("--plan-name", opt->plan_name, "Plan name stored with the run");
    sub->add_option("--serial", opt->serial,
                    "IMU serial stored with the run (default: the recording's)");
    addStoreOption(*sub, &opt->db);
    sub->callback([opt] { runImport(*opt); });
  }
}

}  // namespace imubench::tools
