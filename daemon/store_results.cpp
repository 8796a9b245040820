// The run store's calibration results (daemon/store.h): stored per run, listed by IMU or run.
#include <sqlite3.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "daemon/store.h"
#include "daemon/store_internal.h"

namespace imubench::daemon {

using store_internal::Bound;
using store_internal::nowUnixS;

ResultIdResult Store::storeResult(std::int64_t run_id, const std::string& imu_serial,
                                  double temperature_c, const std::string& kind,
                                  const std::string& json_text) {
  ResultIdResult r;
  if (!std::isfinite(temperature_c)) {
    r.status = impl_->error("cannot store result: temperature is not finite");
    return r;
  }
  if (!nlohmann::json::accept(json_text)) {
    r.status = impl_->error("cannot store result '" + kind + "': not valid JSON");
    return r;
  }
  r.status = impl_->transaction("cannot store result", [&]() {
    RunState state{};
    if (auto st = impl_->runState(run_id, &state); !st.ok) return st;
    Status st;
    Bound q = impl_->use(
        "INSERT INTO results(run_id, imu_serial, temperature_c, kind, json, created_unix_s) "
        "VALUES(?1, ?2, ?3, ?4, ?5, ?6)",
        &st);
    if (!q) return st;
    q.bindAll(run_id, imu_serial, temperature_c, kind, json_text, nowUnixS());
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot store result");
    r.value = sqlite3_last_insert_rowid(impl_->db.get());
    return Status::Ok();
  });
  return r;
}

ResultListResult Store::results(const ResultFilter& filter) {
  ResultListResult r;
  Bound q = impl_->use(
      "SELECT id, run_id, imu_serial, temperature_c, kind, json, created_unix_s FROM results "
      "WHERE (?1 IS NULL OR imu_serial = ?1) AND (?2 IS NULL OR run_id = ?2) ORDER BY id",
      &r.status);
  if (!q) return r;
  if (filter.imu_serial) q.bind(1, *filter.imu_serial);
  if (filter.run_id) q.bind(2, *filter.run_id);
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.push_back(
        {q.integer(0), q.integer(1), q.text(2), q.real(3), q.text(4), q.text(5), q.real(6)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot list results");
  return r;
}

}  // namespace imubench::daemon
