// Reading the lab database (issue 30): what `imubench runs|results|export --db postgresql://...`
// show, across every bench that ships into it. Read-only queries over the schema's views
// (lab/migrations/); parameters are always bound, never spliced into SQL.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lab/lab_connection.h"

namespace imubench::lab {

// True for a --db value that names a PostgreSQL database rather than an SQLite file.
bool isLabUri(const std::string& db);

struct LabRun {
  std::string bench_id;
  std::int64_t run_id = 0;
  std::string plan_name;
  std::string bench_name;
  std::string imu_serial;
  std::string state;
  std::string exit_reason;
  double started_unix_s = 0.0;
  std::optional<double> finished_unix_s;
};

struct LabResult {
  std::string bench_id;
  std::int64_t run_id = 0;
  std::int64_t result_id = 0;
  std::string imu_serial;
  double temperature_c = 0.0;
  std::string kind;
  std::string json;  // the result's JSON text (as PostgreSQL's jsonb prints it)
  double created_unix_s = 0.0;
};

struct LabResultFilter {
  std::optional<std::string> imu_serial;
  std::optional<std::int64_t> run_id;
  std::optional<std::string> bench_id;
};

// Every run of every bench, by bench then run id.
Result<std::vector<LabRun>> readLabRuns(const LabEndpoint& endpoint);
// Results matching the filter (empty fields match all), by bench, run and result id.
Result<std::vector<LabResult>> readLabResults(const LabEndpoint& endpoint,
                                              const LabResultFilter& filter);

}  // namespace imubench::lab
