#include "lab/lab_reader.h"

#include <cstdlib>

namespace imubench::lab {
namespace {

// Runs a parameterised query (nullptr parameters are SQL NULL); a failure names the fault.
Result<PgResult> query(const LabEndpoint& endpoint, PgConn* conn, const char* sql,
                       const std::vector<const char*>& params, const std::string& what) {
  using R = Result<PgResult>;
  if (LabError e = connectLab(endpoint, "imubench", conn); !e.ok()) {
    return R::Error(std::string("lab database (") + labFaultName(e.fault) + "): " + e.message);
  }
  if (LabError e = checkLabSchema(conn->get()); !e.ok()) return R::Error(e.message);
  PgResult r(PQexecParams(conn->get(), sql, static_cast<int>(params.size()), nullptr, params.data(),
                          nullptr, nullptr, 0));
  if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) {
    return R::Error(statementError(conn->get(), r.get(), what).message);
  }
  return {Status::Ok(), std::move(r)};
}

std::string text(const PGresult* r, int row, int col) {
  return PQgetvalue(r, row, col);
}
double real(const PGresult* r, int row, int col) {
  return std::strtod(PQgetvalue(r, row, col), nullptr);
}

}  // namespace

bool isLabUri(const std::string& db) {
  return db.rfind("postgresql://", 0) == 0 || db.rfind("postgres://", 0) == 0;
}

Result<std::vector<LabRun>> readLabRuns(const LabEndpoint& endpoint) {
  Result<std::vector<LabRun>> out;
  PgConn conn;
  auto q = query(endpoint, &conn,
                 "SELECT bench_id, run_id, plan_name, bench_name, imu_serial, state, exit_reason, "
                 "started_unix_s, finished_unix_s FROM lab.runs ORDER BY bench_id, run_id",
                 {}, "cannot list the lab's runs");
  if (!q.ok()) return {q.status, {}};
  const PGresult* r = q.value.get();
  for (int i = 0; i < PQntuples(r); ++i) {
    LabRun run;
    run.bench_id = text(r, i, 0);
    run.run_id = std::strtoll(PQgetvalue(r, i, 1), nullptr, 10);
    run.plan_name = text(r, i, 2);
    run.bench_name = text(r, i, 3);
    run.imu_serial = text(r, i, 4);
    run.state = text(r, i, 5);
    run.exit_reason = text(r, i, 6);
    run.started_unix_s = real(r, i, 7);
    if (!PQgetisnull(r, i, 8)) run.finished_unix_s = real(r, i, 8);
    out.value.push_back(std::move(run));
  }
  return out;
}

Result<std::vector<LabResult>> readLabResults(const LabEndpoint& endpoint,
                                              const LabResultFilter& filter) {
  Result<std::vector<LabResult>> out;
  const std::string run = filter.run_id ? std::to_string(*filter.run_id) : "";
  const std::vector<const char*> params = {filter.imu_serial ? filter.imu_serial->c_str() : nullptr,
                                           filter.run_id ? run.c_str() : nullptr,
                                           filter.bench_id ? filter.bench_id->c_str() : nullptr};
  PgConn conn;
  auto q = query(endpoint, &conn,
                 "SELECT bench_id, run_id, result_id, imu_serial, temperature_c, kind, "
                 "result::text, created_unix_s FROM lab.results "
                 "WHERE ($1::text IS NULL OR imu_serial = $1) "
                 "AND ($2::bigint IS NULL OR run_id = $2::bigint) "
                 "AND ($3::text IS NULL OR bench_id = $3) "
                 "ORDER BY bench_id, run_id, result_id",
                 params, "cannot list the lab's results");
  if (!q.ok()) return {q.status, {}};
  const PGresult* r = q.value.get();
  for (int i = 0; i < PQntuples(r); ++i) {
    LabResult res;
    res.bench_id = text(r, i, 0);
    res.run_id = std::strtoll(PQgetvalue(r, i, 1), nullptr, 10);
    res.result_id = std::strtoll(PQgetvalue(r, i, 2), nullptr, 10);
    res.imu_serial = text(r, i, 3);
    res.temperature_c = real(r, i, 4);
    res.kind = text(r, i, 5);
    res.json = text(r, i, 6);
    res.created_unix_s = real(r, i, 7);
    out.value.push_back(std::move(res));
  }
  return out;
}

}  // namespace imubench::lab
