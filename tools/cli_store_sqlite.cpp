// The run store's work for imubench-store: the SQLite backend of tools/cli_store.h (the store
// subcommands `runs`, `export`, `import`, run ids as recordings, stored results). Registration
// of the subcommands is in cli_runs.cpp, shared with imubench.
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <system_error>

#include "daemon/store.h"
#include "io/recording.h"
#include "io/truth_file.h"
#include "lab/lab_reader.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

const char* tableKindName(calib::TableKind kind) {
  return kind == calib::TableKind::kThreeAxis ? "three-axis" : "two-axis";
}

std::string orDash(const std::string& s) {
  return s.empty() ? "-" : s;
}

enum class StoreAccess {
  kExisting,  // the file must exist (reading commands do not create a database)
  kCreate,    // created with its schema when missing (import)
};

// Opens the store or throws CommandFailed with the store's message.
std::unique_ptr<daemon::Store> openStoreOrFail(const std::string& db_path, StoreAccess access) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (access == StoreAccess::kExisting && !fs::exists(db_path, ec)) {
    throw CommandFailed(db_path + ": no run store here (give --db PATH or set " +
                        std::string(kStorePathEnv) + ")");
  }
  daemon::StoreOpenResult r = daemon::Store::open(db_path);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  return std::move(r.value);
}

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

// ---- the lab database (issue 30): the same readers over every bench's mirrored rows ----

lab::LabEndpoint labEndpoint(const std::string& uri) {
  lab::LabEndpoint e;
  e.conninfo = uri;  // the password from libpq's PGPASSFILE or ~/.pgpass
  return e;
}

void runLabRuns(const RunsOptions& o) {
  const auto runs = lab::readLabRuns(labEndpoint(o.db));
  if (!runs.ok()) throw CommandFailed(runs.status.message);
  if (o.json) {
    nlohmann::json a = nlohmann::json::array();
    for (const lab::LabRun& r : runs.value) {
      a.push_back({{"bench", r.bench_id},
                   {"id", r.run_id},
                   {"state", r.state},
                   {"plan_name", r.plan_name},
                   {"bench_name", r.bench_name},
                   {"imu_serial", r.imu_serial},
                   {"started_unix_s", r.started_unix_s},
                   {"finished_unix_s", r.finished_unix_s ? nlohmann::json(*r.finished_unix_s)
                                                         : nlohmann::json(nullptr)},
                   {"exit_reason", r.exit_reason}});
    }
    std::cout << a.dump(2) << "\n";
    return;
  }
  if (runs.value.empty()) {
    std::cout << "no runs in the lab database\n";
    return;
  }
  std::printf("%-16s  %6s  %-11s  %-20s  %-24s  %-16s  %s\n", "bench", "id", "state",
              "started (UTC)", "plan", "IMU serial", "exit reason");
  for (const lab::LabRun& r : runs.value) {
    std::printf("%-16s  %6lld  %-11s  %-20s  %-24s  %-16s  %s\n", r.bench_id.c_str(),
                static_cast<long long>(r.run_id), r.state.c_str(),
                utcTime(r.started_unix_s).c_str(), orDash(r.plan_name).c_str(),
                orDash(r.imu_serial).c_str(), orDash(r.exit_reason).c_str());
  }
}

std::vector<StoredResultRow> loadLabResults(const std::string& uri,
                                            std::optional<std::int64_t> run_id,
                                            std::optional<std::string> imu_serial,
                                            std::optional<std::string> bench) {
  const auto r = lab::readLabResults(labEndpoint(uri), {std::move(imu_serial), run_id, bench});
  if (!r.ok()) throw CommandFailed(r.status.message);
  std::vector<StoredResultRow> out;
  std::set<std::string> benches;
  for (const lab::LabResult& s : r.value) {
    benches.insert(s.bench_id);
    out.push_back({s.bench_id, s.result_id, s.run_id, s.imu_serial, s.temperature_c, s.kind, s.json,
                   s.created_unix_s});
  }
  if (run_id && benches.size() > 1) {
    std::string names;
    for (const std::string& b : benches) names += (names.empty() ? "" : ", ") + b;
    throw CommandFailed(
        "run " + std::to_string(*run_id) + " is on several benches (" + names + "): give --bench B",
        2);
  }
  return out;
}

StoredRunState loadLabRunState(const std::string& uri, std::int64_t run_id) {
  const auto runs = lab::readLabRuns(labEndpoint(uri));
  if (!runs.ok()) throw CommandFailed(runs.status.message);
  for (const lab::LabRun& r : runs.value) {
    if (r.run_id != run_id) continue;
    StoredRunState st;
    st.plan_name = r.plan_name;
    st.state = r.state;
    st.exit_reason = r.exit_reason;
    return st;  // the step events are in the lab too, but not read here
  }
  throw CommandFailed("run " + std::to_string(run_id) + " is not in the lab database");
}

}  // namespace

std::string runStoreProgram(char** /*argv*/) {
  return "internal error: imubench-store links the run store and delegates to nobody";
}

io::Recording loadStoredRun(std::int64_t id, const std::string& db_path) {
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(db_path, StoreAccess::kExisting);
  io::RecordingReadResult r = store->loadRecording(id);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  return std::move(r.value);
}

std::int64_t storeRunResult(const std::string& db_path, std::int64_t run_id,
                            const std::string& imu_serial, double temperature_c,
                            const std::string& kind, const std::string& json) {
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(db_path, StoreAccess::kExisting);
  const daemon::ResultIdResult r =
      store->storeResult(run_id, imu_serial, temperature_c, kind, json);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  return r.value;
}

// ---- runs ----

void runRuns(const RunsOptions& o) {
  if (lab::isLabUri(o.db)) {
    runLabRuns(o);
    return;
  }
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kExisting);
  const daemon::RunListResult list = store->listRuns();
  if (!list.status.ok) throw CommandFailed(list.status.message);
  if (o.json) {
    nlohmann::json a = nlohmann::json::array();
    for (const daemon::RunInfo& r : list.value) a.push_back(runJson(r));
    std::cout << a.dump(2) << "\n";
    return;
  }
  if (list.value.empty()) {
    std::cout << "no runs in " << o.db << "\n";
    return;
  }
  std::printf("%6s  %-11s  %-20s  %-24s  %-16s  %s\n", "id", "state", "started (UTC)", "plan",
              "IMU serial", "exit reason");
  for (const daemon::RunInfo& r : list.value) {
    std::printf("%6lld  %-11s  %-20s  %-24s  %-16s  %s\n", static_cast<long long>(r.id),
                daemon::runStateName(r.state), utcTime(r.started_unix_s).c_str(),
                orDash(r.start.plan_name).c_str(), orDash(r.start.imu_serial).c_str(),
                orDash(r.exit_reason).c_str());
  }
}

// ---- export ----

void runExport(const ExportOptions& o) {
  const std::optional<std::int64_t> id = parseRunId(o.run);
  if (!id) throw CommandFailed("'" + o.run + "' is not a run id (N or run:N, N >= 1)", 2);
  if (lab::isLabUri(o.db)) {
    throw CommandFailed(
        "export: exporting a recording from the lab database is not built: its raw samples "
        "are there bit-exact (from benches with [lab] mirror_samples = true: lab.imu_samples, "
        "lab.table_samples, lab.chamber_samples), but a run's meta data and segments travel as "
        "SQLite JSON, which keeps 15 significant digits and drops the sign of -0.0, so the "
        "recording would not be the bench's: export it from the bench's own store (--db PATH); "
        "`results RUN --db postgresql://... --bench B --json` gives its results");
  }
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kExisting);
  const io::RecordingReadResult rec = store->loadRecording(*id);
  if (!rec.status.ok) throw CommandFailed(rec.status.message);
  if (const Status s = io::writeRecording(o.csv_dir, rec.value); !s.ok) {
    throw CommandFailed(s.message);
  }
  std::cout << "run " << *id << " written to " << o.csv_dir << " (" << io::kRecordingFormat << ", "
            << rec.value.imu.size() << " IMU samples)\n";
  if (o.results.empty()) return;
  daemon::ResultFilter filter;
  filter.run_id = *id;
  const daemon::ResultListResult results = store->results(filter);
  if (!results.status.ok) throw CommandFailed(results.status.message);
  nlohmann::json a = nlohmann::json::array();
  for (const daemon::StoredResult& r : results.value) {
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
  if (const Status s = io::writeJsonFile(o.results, a); !s.ok) {
    throw CommandFailed(s.message);
  }
  std::cout << results.value.size() << " result(s) of run " << *id << " written to " << o.results
            << "\n";
}

// ---- import ----

void runImport(const ImportOptions& o) {
  const io::RecordingReadResult rec = io::readRecording(o.dir);
  if (!rec.status.ok) throw CommandFailed(rec.status.message);
  daemon::RunStart start = daemon::runStartFromRecording(rec.value);
  start.plan_name = o.plan_name;
  if (o.serial) start.imu_serial = *o.serial;
  const std::unique_ptr<daemon::Store> store = openStoreOrFail(o.db, StoreAccess::kCreate);
  const daemon::RunIdResult r = store->importRecording(start, rec.value);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  std::cerr << "imported " << o.dir << " into " << o.db << " as run " << r.value << "\n";
  std::cout << r.value << "\n";
}

std::vector<StoredResultRow> loadStoredResults(const std::string& db_path,
                                               std::optional<std::int64_t> run_id,
                                               std::optional<std::string> imu_serial,
                                               std::optional<std::string> bench) {
  if (lab::isLabUri(db_path)) return loadLabResults(db_path, run_id, imu_serial, bench);
  if (bench) throw CommandFailed("--bench applies to the lab database (--db postgresql://...)", 2);
  auto store = openStoreOrFail(db_path, StoreAccess::kExisting);
  if (run_id) {
    const daemon::RunInfoResult info = store->runInfo(*run_id);
    if (!info.status.ok) throw CommandFailed(info.status.message);
  }
  daemon::ResultFilter filter;
  filter.run_id = run_id;
  filter.imu_serial = std::move(imu_serial);
  const daemon::ResultListResult r = store->results(filter);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  std::vector<StoredResultRow> out;
  for (const daemon::StoredResult& s : r.value) {
    out.push_back(
        {"", s.id, s.run_id, s.imu_serial, s.temperature_c, s.kind, s.json, s.created_unix_s});
  }
  return out;
}

StoredRunState loadRunState(const std::string& db_path, std::int64_t run_id) {
  if (lab::isLabUri(db_path)) return loadLabRunState(db_path, run_id);
  auto store = openStoreOrFail(db_path, StoreAccess::kExisting);
  const daemon::RunInfoResult info = store->runInfo(run_id);
  if (!info.status.ok) throw CommandFailed(info.status.message);
  StoredRunState out;
  out.plan_name = info.value.start.plan_name;
  out.plan_toml = info.value.start.plan_toml;
  out.bench_name = info.value.start.bench_name;
  out.imu_serial = info.value.start.imu_serial;
  out.started_unix_s = info.value.started_unix_s;
  out.finished_unix_s = info.value.finished_unix_s;
  out.state = daemon::runStateName(info.value.state);
  out.exit_reason = info.value.exit_reason;
  const daemon::EventListResult events = store->events(run_id);
  if (!events.status.ok) throw CommandFailed(events.status.message);
  for (const daemon::RunEvent& e : events.value) {
    if (e.kind != "step_started" && e.kind != "step_finished") continue;
    const nlohmann::json j = nlohmann::json::parse(e.json, nullptr, false);
    if (!j.is_object() || !j.contains("step") || !j["step"].is_number_integer()) continue;
    const int step = j["step"].get<int>();
    if (e.kind == "step_finished") {
      out.last_finished_step = step;
    } else {
      out.step = step;
      const auto label = j.find("label");
      out.step_label = label != j.end() && label->is_string() ? label->get<std::string>() : "";
    }
  }
  return out;
}

}  // namespace imubench::tools
