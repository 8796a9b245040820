// The run store (daemon/store.h), in parts by what they store:
//   store.cpp               the connection, the schema and its migrations, Store::open, the
//                           helpers every part uses (store_internal.h declares them)
//   store_runs.cpp          runs: start, end, interruption and resume, their events, the
//                           discarding of segments a resumed run re-runs
//   store_samples.cpp       sample rows and segments going in: checks, batches, RunWriter, import
//   store_sample_reads.cpp  sample rows coming out: the recording, the round trips, the lab
//                           mirror's sample streams
//   store_results.cpp       calibration results
//   store_queue.cpp         the plan queue
//   store_outbox.cpp        the lab mirror's outbox
#include "daemon/store.h"

#include <sqlite3.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "daemon/store_internal.h"

namespace imubench::daemon {
namespace {

// Sample columns are declared ANY (STRICT tables), not REAL: SQLite writes an integral value
// of a REAL-affinity column as an integer and reads it back as +0.0 for -0.0, which breaks the
// bit-exact round trip. ANY keeps the IEEE double as bound. NaN is stored as NULL by SQLite,
// which is what imu_samples.temp_c needs ("not reported").
//
// imu/table/chamber samples are WITHOUT ROWID tables keyed by (run_id, t): the primary key is
// the (run_id, t) index, rows are clustered in time order, and a duplicate time is refused.
constexpr const char* kSchemaSql = R"sql(
CREATE TABLE runs(
  id INTEGER PRIMARY KEY,
  plan_name TEXT NOT NULL,
  plan_toml TEXT NOT NULL,
  bench_name TEXT NOT NULL,
  imu_serial TEXT NOT NULL,
  imu_rate_hz ANY NOT NULL,
  latitude_deg ANY NOT NULL,
  height_m ANY NOT NULL,
  gravity_mps2 ANY,
  table_kind TEXT NOT NULL CHECK(table_kind IN ('two-axis', 'three-axis')),
  outer_axis_heading_deg ANY,
  segments_from_file INTEGER NOT NULL,
  started_unix_s REAL NOT NULL,
  finished_unix_s REAL,
  state TEXT NOT NULL
    CHECK(state IN ('running', 'finished', 'aborted', 'faulted', 'interrupted')),
  exit_reason TEXT NOT NULL DEFAULT ''
) STRICT;
CREATE INDEX runs_by_state ON runs(state);
CREATE TABLE events(
  id INTEGER PRIMARY KEY,
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  wall_unix_s REAL NOT NULL,
  severity TEXT NOT NULL CHECK(severity IN ('info', 'warning', 'error')),
  kind TEXT NOT NULL,
  json TEXT NOT NULL
) STRICT;
CREATE INDEX events_by_run ON events(run_id, wall_unix_s);
CREATE TABLE imu_samples(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  t ANY NOT NULL,
  dthx ANY NOT NULL, dthy ANY NOT NULL, dthz ANY NOT NULL,
  dvx ANY NOT NULL, dvy ANY NOT NULL, dvz ANY NOT NULL,
  temp_c ANY,
  PRIMARY KEY(run_id, t)
) STRICT, WITHOUT ROWID;
CREATE TABLE table_samples(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  t ANY NOT NULL,
  angle0_deg ANY NOT NULL, angle1_deg ANY NOT NULL, angle2_deg ANY NOT NULL,
  round_trip_s ANY,
  PRIMARY KEY(run_id, t)
) STRICT, WITHOUT ROWID;
CREATE TABLE chamber_samples(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  t ANY NOT NULL,
  setpoint_c ANY NOT NULL,
  temp_c ANY NOT NULL,
  PRIMARY KEY(run_id, t)
) STRICT, WITHOUT ROWID;
CREATE TABLE segments(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  idx INTEGER NOT NULL,
  t0 ANY NOT NULL,
  t1 ANY NOT NULL,
  kind TEXT NOT NULL CHECK(kind IN ('static', 'rotate', 'move', 'soak')),
  label TEXT NOT NULL,
  recording INTEGER NOT NULL,
  axis INTEGER NOT NULL,
  angle_rad ANY NOT NULL,
  PRIMARY KEY(run_id, idx)
) STRICT, WITHOUT ROWID;
CREATE TABLE results(
  id INTEGER PRIMARY KEY,
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  imu_serial TEXT NOT NULL,
  temperature_c ANY NOT NULL,
  kind TEXT NOT NULL,
  json TEXT NOT NULL,
  created_unix_s REAL NOT NULL
) STRICT;
CREATE INDEX results_by_serial ON results(imu_serial, temperature_c);
CREATE INDEX results_by_run ON results(run_id);
)sql";

// Schema version 2: the plan queue (a new database gets it with the rest; a version 1 one is
// migrated when opened). pos orders the entries (gaps allowed); AUTOINCREMENT: an entry's id is
// never reused, so an operator's "remove 3" cannot hit a later entry.
constexpr const char* kQueueSchemaSql = R"sql(
CREATE TABLE queue(
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  pos INTEGER NOT NULL,
  plan_name TEXT NOT NULL,
  source TEXT NOT NULL,
  plan_toml TEXT NOT NULL,
  label TEXT NOT NULL,
  added_unix_s REAL NOT NULL
) STRICT;
CREATE INDEX queue_by_pos ON queue(pos);
)sql";
// Schema version 3: each table reading's read round trip, s (RunBatch::table_round_trip_s;
// NULL: unknown, as in every row stored before).
constexpr const char* kRoundTripColumnSql = "ALTER TABLE table_samples ADD COLUMN round_trip_s ANY";
constexpr const char* kHasRoundTripColumnSql =
    "SELECT count(*) FROM pragma_table_info('table_samples') WHERE name = 'round_trip_s'";
// Schema version 4: the lab mirror's outbox (issue 30, lab/shipper.h). What must reach the lab
// database is written to lab_outbox by triggers, so it lands in the same transaction as the
// data it copies; the shipper reads it in seq order and deletes what the lab has committed.
// The triggers only fire once the outbox is enabled (Store::enableOutbox: a bench without a
// lab database keeps no outbox). Each lab_item_* view is the one definition of an item's key
// (run_id, item) and payload, used by the triggers and by enableOutbox's backfill alike.
constexpr const char* kOutboxSchemaSql = R"sql(
CREATE TABLE lab_outbox(
  seq INTEGER PRIMARY KEY AUTOINCREMENT,
  run_id INTEGER NOT NULL,
  item TEXT NOT NULL,
  kind TEXT NOT NULL,
  op TEXT NOT NULL CHECK(op IN ('upsert', 'delete')),
  payload TEXT NOT NULL
) STRICT;
CREATE TABLE lab_outbox_enabled(one INTEGER PRIMARY KEY CHECK(one = 1)) STRICT;
CREATE VIEW lab_item_runs AS SELECT id AS run_id, 'run' AS item, 'run' AS kind,
  json_object('id', id, 'plan_name', plan_name, 'plan_toml', plan_toml, 'bench_name', bench_name,
    'imu_serial', imu_serial, 'imu_rate_hz', imu_rate_hz, 'latitude_deg', latitude_deg,
    'height_m', height_m, 'gravity_mps2', gravity_mps2, 'table_kind', table_kind,
    'outer_axis_heading_deg', outer_axis_heading_deg, 'segments_from_file', segments_from_file,
    'started_unix_s', started_unix_s, 'finished_unix_s', finished_unix_s, 'state', state,
    'exit_reason', exit_reason) AS payload FROM runs;
CREATE VIEW lab_item_events AS SELECT run_id, 'event/' || id AS item, 'event' AS kind,
  json_object('id', id, 'wall_unix_s', wall_unix_s, 'severity', severity, 'kind', kind,
    'details', json(json)) AS payload FROM events;
CREATE VIEW lab_item_results AS SELECT run_id, 'result/' || id AS item, 'result' AS kind,
  json_object('id', id, 'imu_serial', imu_serial, 'temperature_c', temperature_c, 'kind', kind,
    'result', json(json), 'created_unix_s', created_unix_s) AS payload FROM results;
CREATE VIEW lab_item_segments AS SELECT run_id, 'segment/' || idx AS item, 'segment' AS kind,
  json_object('idx', idx, 't0', t0, 't1', t1, 'kind', kind, 'label', label,
    'recording', recording, 'axis', axis, 'angle_rad', angle_rad) AS payload FROM segments;
CREATE VIEW lab_item_queue AS SELECT 0 AS run_id, 'queue/' || id AS item, 'queue' AS kind,
  json_object('id', id, 'plan_name', plan_name, 'source', source, 'plan_toml', plan_toml,
    'label', label, 'added_unix_s', added_unix_s, 'left_unix_s', NULL) AS payload FROM queue;
CREATE TRIGGER lab_run_insert AFTER INSERT ON runs WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_runs WHERE run_id = NEW.id; END;
CREATE TRIGGER lab_run_update AFTER UPDATE ON runs WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_runs WHERE run_id = NEW.id; END;
CREATE TRIGGER lab_event_insert AFTER INSERT ON events
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_events
  WHERE item = 'event/' || NEW.id; END;
CREATE TRIGGER lab_result_insert AFTER INSERT ON results
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_results
  WHERE item = 'result/' || NEW.id; END;
CREATE TRIGGER lab_segment_insert AFTER INSERT ON segments
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_segments
  WHERE run_id = NEW.run_id AND item = 'segment/' || NEW.idx; END;
CREATE TRIGGER lab_segment_delete AFTER DELETE ON segments
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  VALUES(OLD.run_id, 'segment/' || OLD.idx, 'segment', 'delete', '{}'); END;
CREATE TRIGGER lab_queue_insert AFTER INSERT ON queue
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_queue
  WHERE item = 'queue/' || NEW.id; END;
CREATE TRIGGER lab_queue_delete BEFORE DELETE ON queue
WHEN EXISTS(SELECT 1 FROM lab_outbox_enabled)
BEGIN INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert',
    json_set(payload, '$.left_unix_s', (julianday('now') - 2440587.5) * 86400.0) FROM lab_item_queue
  WHERE item = 'queue/' || OLD.id; END;
)sql";
constexpr const char* kSetSchemaVersionSql = "PRAGMA user_version=4";
static_assert(kStoreSchemaVersion == 4, "kSetSchemaVersionSql writes version 4");

}  // namespace

namespace store_internal {

double nowUnixS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string runLabel(std::int64_t run_id) {
  return "run " + std::to_string(run_id);
}

}  // namespace store_internal

using store_internal::Bound;
using store_internal::runLabel;

// ---------------------------------------------------------------------------------------
// Store::Impl: opening the connection, the schema

Status Store::Impl::openConnection() {
  sqlite3* raw = nullptr;
  const int rc =
      sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  db.reset(raw);  // sqlite3_open_v2 hands out a handle even on failure; close it either way
  if (rc != SQLITE_OK) {
    return error(std::string("cannot open database: ") +
                 (raw != nullptr ? sqlite3_errmsg(raw) : sqlite3_errstr(rc)));
  }
  sqlite3_extended_result_codes(db.get(), 1);
  sqlite3_busy_timeout(db.get(), options.busy_timeout_ms);
  return Status::Ok();
}

// The first read of the file: also where a file that is not SQLite is found.
Status Store::Impl::checkSchemaVersion(std::int64_t* version) {
  Status st;
  Bound q = use("PRAGMA user_version", &st);
  if (!q || q.step() != SQLITE_ROW) {
    if (!notADatabase()) return sqlError("cannot read the schema version");
    return error(std::string("not an SQLite database, or corrupted (") + sqlite3_errmsg(db.get()) +
                 ")");
  }
  *version = q.integer(0);
  if (*version > kStoreSchemaVersion) {
    return error("schema version " + std::to_string(*version) +
                 " is newer than this imubench supports (" + std::to_string(kStoreSchemaVersion) +
                 "); use a newer imubench");
  }
  if (*version < 0) return error("invalid schema version " + std::to_string(*version));
  return Status::Ok();
}

Status Store::Impl::configure() {
  Status st;
  {
    Bound q = use("PRAGMA journal_mode=WAL", &st);
    if (!q) return st;
    if (q.step() != SQLITE_ROW) return sqlError("cannot switch to WAL mode");
    const std::string mode = q.text(0);
    // An in-memory database (":memory:", tests) has no WAL and needs none.
    if (mode != "wal" && mode != "memory")
      return error("cannot switch to WAL mode (journal mode stays '" + mode + "')");
  }
  // FULL in WAL mode: every commit is synced, so a power loss (not only a process crash) loses
  // at most the writer's unflushed tail. With NORMAL the WAL is synced only at checkpoints: a
  // power loss could drop a minute of samples. The writer commits twice a second: cheap.
  if (st = execSql("PRAGMA synchronous=FULL", "cannot set synchronous"); !st.ok) return st;
  return execSql("PRAGMA foreign_keys=ON", "cannot enable foreign keys");
}

Status Store::Impl::createSchemaIfNew() {
  return transaction("cannot create the schema", [&]() {
    std::int64_t version = 0;
    std::int64_t objects = 0;
    // Re-read inside the write transaction: another process may have created it meanwhile.
    if (auto st = checkSchemaVersion(&version); !st.ok || version != 0) return st;
    if (auto st =
            queryInt("SELECT count(*) FROM sqlite_schema", "cannot read the schema", &objects);
        !st.ok) {
      return st;
    }
    if (objects != 0) return error("not an imubench store (has tables but no schema version)");
    if (auto st = execSql(kSchemaSql, "cannot create the schema"); !st.ok) return st;
    if (auto st = execSql(kQueueSchemaSql, "cannot create the schema"); !st.ok) return st;
    if (auto st = execSql(kOutboxSchemaSql, "cannot create the schema"); !st.ok) return st;
    return execSql(kSetSchemaVersionSql, "cannot set the schema version");
  });
}

// Version 1 (before the queue) -> 2 -> 3 (before the round trips) -> 4 (before the outbox).
Status Store::Impl::migrateSchema() {
  return transaction("cannot migrate the schema to version 4", [&]() {
    std::int64_t version = 0;
    // Re-read inside the write transaction: another process may have migrated it meanwhile.
    if (auto st = checkSchemaVersion(&version); !st.ok || version < 1 || version > 3) return st;
    if (version == 1) {
      if (auto st = execSql(kQueueSchemaSql, "cannot add the queue"); !st.ok) return st;
    }
    // After the queue: the outbox's triggers watch it. Skipped when it exists (a database
    // whose version was set back by hand, as the tests do).
    std::int64_t has_outbox = 0;
    if (auto st = queryInt("SELECT count(*) FROM sqlite_schema WHERE name = 'lab_outbox'",
                           "cannot read the schema", &has_outbox);
        !st.ok) {
      return st;
    }
    if (has_outbox == 0) {
      if (auto st = execSql(kOutboxSchemaSql, "cannot add the lab outbox"); !st.ok) return st;
    }
    if (version == 3) return execSql(kSetSchemaVersionSql, "cannot set the schema version");
    std::int64_t has_column = 0;
    if (auto st =
            queryInt(kHasRoundTripColumnSql, "cannot read the table samples' columns", &has_column);
        !st.ok) {
      return st;
    }
    if (has_column == 0) {
      if (auto st = execSql(kRoundTripColumnSql, "cannot add the round trips"); !st.ok) return st;
    }
    return execSql(kSetSchemaVersionSql, "cannot set the schema version");
  });
}

Status Store::Impl::lastTime(const char* sql, std::int64_t run_id, std::optional<double>* out) {
  Status st;
  Bound q = use(sql, &st);
  if (!q) return st;
  q.bind(1, run_id);
  if (q.step() != SQLITE_ROW) return sqlError("cannot read the end of " + runLabel(run_id));
  *out = q.optReal(0);
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------
// Public API

bool StoreOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (busy_timeout_ms < 0) return fail("busy_timeout_ms must be >= 0");
  if (!(max_unflushed_s > 0.0) || !std::isfinite(max_unflushed_s))
    return fail("max_unflushed_s must be positive and finite");
  if (max_unflushed_rows < 1) return fail("max_unflushed_rows must be >= 1");
  return true;
}

Store::Store(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Store::~Store() = default;

const std::string& Store::path() const {
  return impl_->path;
}
const StoreOptions& Store::options() const {
  return impl_->options;
}

StoreOpenResult Store::open(const std::string& path, const StoreOptions& options) {
  StoreOpenResult r;
  std::string why;
  if (!options.IsValid(&why)) {
    r.status = Status::Error(path + ": invalid store options: " + why);
    return r;
  }
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->options = options;
  std::int64_t version = 0;
  Status st = impl->openConnection();
  if (st.ok) st = impl->checkSchemaVersion(&version);
  if (st.ok) st = impl->configure();
  if (st.ok && version == 0) st = impl->createSchemaIfNew();
  if (st.ok && version >= 1 && version < kStoreSchemaVersion) st = impl->migrateSchema();
  if (!st.ok) {
    r.status = st;
    return r;
  }
  r.value.reset(new Store(std::move(impl)));
  return r;
}

Status Store::integrityCheck() {
  Status st;
  Bound q = impl_->use("PRAGMA integrity_check", &st);
  if (!q) return st;
  std::string problems;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    const std::string line = q.text(0);
    if (line != "ok") problems += (problems.empty() ? "" : "; ") + line;
  }
  if (rc != SQLITE_DONE) return impl_->sqlError("integrity check failed");
  if (!problems.empty()) return impl_->error("integrity check: " + problems);
  return Status::Ok();
}

}  // namespace imubench::daemon
