#include "daemon/store.h"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <utility>

#include "io/enum_names.h"

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
// enableOutbox's backfill: everything stored before the outbox was enabled, in a stable order.
constexpr const char* kOutboxBackfillSql = R"sql(
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_runs ORDER BY run_id;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_segments;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_events;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_results;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_queue;
INSERT INTO lab_outbox_enabled VALUES(1);
)sql";
constexpr const char* kSetSchemaVersionSql = "PRAGMA user_version=4";
static_assert(kStoreSchemaVersion == 4, "kSetSchemaVersionSql writes version 4");

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The newest stored IMU sample of run ?1 (NULL: none).
constexpr const char* kLastImuTSql = "SELECT max(t) FROM imu_samples WHERE run_id = ?1";

// A raw sample stream's SQL (SampleStream): its newest row of run ?1, its rows of run ?1 after
// time ?2 (-inf: all) in time order up to ?3, and how many those are. Literals, so the
// statement cache (keyed by the SQL's address) prepares each once.
struct StreamSql {
  const char* name;
  const char* newest_t;
  const char* read;
  const char* count;
  std::span<const char* const> columns;
};
constexpr const char* kImuColumns[] = {"dthx", "dthy", "dthz", "dvx", "dvy", "dvz", "temp_c"};
constexpr const char* kTableColumns[] = {"angle0_deg", "angle1_deg", "angle2_deg", "round_trip_s"};
constexpr const char* kChamberColumns[] = {"setpoint_c", "temp_c"};
const StreamSql& streamSql(SampleStream stream) {
  static const StreamSql kImu{"imu", kLastImuTSql,
                              "SELECT t, dthx, dthy, dthz, dvx, dvy, dvz, temp_c FROM imu_samples "
                              "WHERE run_id = ?1 AND t > ?2 ORDER BY t LIMIT ?3",
                              "SELECT count(*) FROM imu_samples WHERE run_id = ?1 AND t > ?2",
                              kImuColumns};
  static const StreamSql kTable{
      "table", "SELECT max(t) FROM table_samples WHERE run_id = ?1",
      "SELECT t, angle0_deg, angle1_deg, angle2_deg, round_trip_s FROM table_samples "
      "WHERE run_id = ?1 AND t > ?2 ORDER BY t LIMIT ?3",
      "SELECT count(*) FROM table_samples WHERE run_id = ?1 AND t > ?2", kTableColumns};
  static const StreamSql kChamber{
      "chamber", "SELECT max(t) FROM chamber_samples WHERE run_id = ?1",
      "SELECT t, setpoint_c, temp_c FROM chamber_samples "
      "WHERE run_id = ?1 AND t > ?2 ORDER BY t LIMIT ?3",
      "SELECT count(*) FROM chamber_samples WHERE run_id = ?1 AND t > ?2", kChamberColumns};
  switch (stream) {
    case SampleStream::kTable:
      return kTable;
    case SampleStream::kChamber:
      return kChamber;
    case SampleStream::kImu:
      break;
  }
  return kImu;
}

// All runs (?1 NULL) or one; read by Store::Impl::readRun.
constexpr const char* kSelectRunsSql =
    "SELECT id, plan_name, plan_toml, bench_name, imu_serial, imu_rate_hz, latitude_deg, "
    "height_m, gravity_mps2, table_kind, outer_axis_heading_deg, segments_from_file, "
    "started_unix_s, finished_unix_s, state, exit_reason FROM runs "
    "WHERE ?1 IS NULL OR id = ?1 ORDER BY id";

double nowUnixS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

const char* tableKindName(calib::TableKind kind) {
  return kind == calib::TableKind::kTwoAxis ? "two-axis" : "three-axis";
}

std::optional<calib::SegmentKind> segmentKindFromName(std::string_view name) {
  for (auto k : {calib::SegmentKind::kStatic, calib::SegmentKind::kRotate,
                 calib::SegmentKind::kMove, calib::SegmentKind::kSoak}) {
    if (name == calib::segmentKindName(k)) return k;
  }
  return std::nullopt;
}

// An operator's abort is worth a warning; a fault is an error.
EventSeverity endSeverity(RunState state) {
  if (state == RunState::kFinished) return EventSeverity::kInfo;
  if (state == RunState::kAborted) return EventSeverity::kWarning;
  return EventSeverity::kError;
}

std::string runLabel(std::int64_t run_id) {
  return "run " + std::to_string(run_id);
}

// ---------------------------------------------------------------------------------------
// Row checks shared by RunWriter (per append call) and Store (per batch)

bool finiteRow(const nav::ImuSample& s) {
  // temp_c NaN means "not reported"; infinity is a broken reading.
  return std::isfinite(s.t) && s.dtheta.allFinite() && s.dvel.allFinite() && !std::isinf(s.temp_c);
}
bool finiteRow(const io::TableSample& s) {
  return std::isfinite(s.t) && std::isfinite(s.angles_deg[0]) && std::isfinite(s.angles_deg[1]) &&
         std::isfinite(s.angles_deg[2]);
}
bool finiteRow(const io::ChamberSample& s) {
  return std::isfinite(s.t) && std::isfinite(s.setpoint_c) && std::isfinite(s.temp_c);
}

// Finite values and strictly increasing times (also after `last_t`, the previous row).
template <typename Row>
Status checkRows(const char* what, std::span<const Row> rows, std::optional<double> last_t) {
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!finiteRow(rows[i])) {
      return Status::Error(std::string(what) + " " + std::to_string(i) + " has a non-finite value");
    }
    if (last_t && !(rows[i].t > *last_t)) {
      return Status::Error(std::string(what) + " " + std::to_string(i) +
                           ": time does not increase");
    }
    last_t = rows[i].t;
  }
  return Status::Ok();
}

Status checkSegments(std::span<const calib::Segment> segments, std::optional<double> last_t1) {
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const auto& s = segments[i];
    const std::string which = "segment " + std::to_string(i);
    if (!std::isfinite(s.t0) || !std::isfinite(s.t1) || !std::isfinite(s.angle))
      return Status::Error(which + " has a non-finite value");
    if (!(s.t1 > s.t0)) return Status::Error(which + ": t1 is not after t0");
    if (last_t1 && s.t0 < *last_t1)
      return Status::Error(which + " starts before the previous one ends");
    last_t1 = s.t1;
  }
  return Status::Ok();
}

// Round trips: none, or one per table row, each unknown (NaN) or finite and >= 0.
Status checkRoundTrips(std::span<const double> round_trip_s, std::size_t rows) {
  if (!round_trip_s.empty() && round_trip_s.size() != rows) {
    return Status::Error(std::to_string(round_trip_s.size()) + " round trips for " +
                         std::to_string(rows) + " table samples");
  }
  for (std::size_t i = 0; i < round_trip_s.size(); ++i) {
    const double rt = round_trip_s[i];
    if (!std::isnan(rt) && !(std::isfinite(rt) && rt >= 0.0))
      return Status::Error("table sample " + std::to_string(i) + ": invalid round trip");
  }
  return Status::Ok();
}

Status checkBatch(const RunBatch& b) {
  if (auto st = checkRows<nav::ImuSample>("IMU sample", b.imu, std::nullopt); !st.ok) return st;
  if (auto st = checkRows<io::TableSample>("table sample", b.table, std::nullopt); !st.ok)
    return st;
  if (auto st = checkRoundTrips(b.table_round_trip_s, b.table.size()); !st.ok) return st;
  if (auto st = checkRows<io::ChamberSample>("chamber sample", b.chamber, std::nullopt); !st.ok)
    return st;
  return checkSegments(b.segments, std::nullopt);
}

// ---------------------------------------------------------------------------------------
// SQLite RAII

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
using DbPtr = std::unique_ptr<sqlite3, DbCloser>;

struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using StmtPtr = std::unique_ptr<sqlite3_stmt, StmtFinalizer>;

// A cached prepared statement in use. Reset and unbound when it goes out of scope, so no read
// transaction lingers and bound text may be static (bound only for this use).
class Bound {
 public:
  explicit Bound(sqlite3_stmt* s) : s_(s) {}
  ~Bound() {
    if (s_ != nullptr) {
      sqlite3_reset(s_);
      sqlite3_clear_bindings(s_);
    }
  }
  Bound(const Bound&) = delete;
  Bound& operator=(const Bound&) = delete;

  explicit operator bool() const { return s_ != nullptr; }
  // NaN is bound as NULL by SQLite.
  void bind(int i, double v) { sqlite3_bind_double(s_, i, v); }
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(s_, i, v); }
  void bind(int i, int v) { sqlite3_bind_int(s_, i, v); }
  // nullptr destructor is SQLITE_STATIC (the macro is an old-style cast): the text outlives
  // this use, and clear_bindings drops it before the caller's string can go away.
  void bind(int i, std::string_view v) {
    sqlite3_bind_text64(s_, i, v.data(), v.size(), nullptr, SQLITE_UTF8);
  }
  void bind(int i, const std::optional<double>& v) {
    if (v) {
      bind(i, *v);
    } else {
      sqlite3_bind_null(s_, i);
    }
  }
  void bindNull(int i) { sqlite3_bind_null(s_, i); }
  // Binds ?1, ?2, ... to `values` in order.
  template <class... V>
  void bindAll(const V&... values) {
    int i = 0;
    (bind(++i, values), ...);
  }
  int step() { return sqlite3_step(s_); }
  // Once stepped, the next use starts over (hot insert loops reuse one Bound).
  void rewind() { sqlite3_reset(s_); }

  bool isNull(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL; }
  double real(int c) const { return sqlite3_column_double(s_, c); }
  double realOrNaN(int c) const {
    return isNull(c) ? std::numeric_limits<double>::quiet_NaN() : real(c);
  }
  std::optional<double> optReal(int c) const {
    return isNull(c) ? std::nullopt : std::optional<double>(real(c));
  }
  std::int64_t integer(int c) const { return sqlite3_column_int64(s_, c); }
  std::string text(int c) const {
    const auto* p = sqlite3_column_text(s_, c);
    const int n = sqlite3_column_bytes(s_, c);
    return p == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(p), n);
  }

 private:
  sqlite3_stmt* s_;
};

}  // namespace

// ---------------------------------------------------------------------------------------
// Store::Impl: the connection, its cached statements and the SQL helpers

struct Store::Impl {
  std::string path;
  StoreOptions options;
  DbPtr db;
  std::unordered_map<const char*, StmtPtr> statements;  // keyed by the SQL literal

  Status sqlError(std::string_view what) const {
    return Status::Error(path + ": " + std::string(what) + ": " + sqlite3_errmsg(db.get()));
  }
  // A file that is not SQLite, or is damaged, fails with these codes on its first read.
  bool notADatabase() const {
    const int code = sqlite3_errcode(db.get()) & 0xff;
    return code == SQLITE_NOTADB || code == SQLITE_CORRUPT;
  }
  Status error(std::string_view what) const {
    return Status::Error(path + ": " + std::string(what));
  }

  // The cached statement for `sql` (a string literal), prepared on first use.
  Bound use(const char* sql, Status* st) {
    auto& slot = statements[sql];
    if (!slot) {
      sqlite3_stmt* s = nullptr;
      if (sqlite3_prepare_v3(db.get(), sql, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) !=
          SQLITE_OK) {
        *st = sqlError("cannot prepare statement");
        statements.erase(sql);
        return Bound(nullptr);
      }
      slot.reset(s);
    }
    return Bound(slot.get());
  }

  Status execSql(const char* sql, std::string_view what) {
    char* msg = nullptr;
    if (sqlite3_exec(db.get(), sql, nullptr, nullptr, &msg) == SQLITE_OK) return Status::Ok();
    std::string why = msg != nullptr ? msg : sqlite3_errmsg(db.get());
    sqlite3_free(msg);
    return error(std::string(what) + ": " + why);
  }

  // Runs `body` (returning Status) in one write transaction; rolls back on failure.
  template <typename Fn>
  Status transaction(std::string_view what, Fn&& body) {
    if (auto st = execSql("BEGIN IMMEDIATE", what); !st.ok) return st;
    Status st = body();
    if (st.ok) st = execSql("COMMIT", what);
    if (!st.ok) sqlite3_exec(db.get(), "ROLLBACK", nullptr, nullptr, nullptr);
    return st;
  }

  // A single integer from a query without parameters (pragmas, counts).
  Status queryInt(const char* sql, std::string_view what, std::int64_t* out) {
    Status st;
    Bound q = use(sql, &st);
    if (!q) return st;
    if (q.step() != SQLITE_ROW) return sqlError(what);
    *out = q.integer(0);
    return Status::Ok();
  }

  Status openConnection();
  Status checkSchemaVersion(std::int64_t* version);
  Status configure();
  Status createSchemaIfNew();
  Status migrateSchema();
  Status queueIds(std::vector<std::int64_t>* ids);
  Status runState(std::int64_t run_id, RunState* state);
  // A one-value query on run ?1 (a max(...)); NULL leaves *out unset.
  Status lastTime(const char* sql, std::int64_t run_id, std::optional<double>* out);
  Status requireRunning(std::int64_t run_id);
  // Each stream's first row of `batch` comes after the stream's newest stored row.
  Status requireAfterStored(std::int64_t run_id, const RunBatch& batch);
  Status insertRun(const RunStart& start, RunState state, std::int64_t* run_id);
  Status insertEvent(const RunEvent& event);
  Status insertRows(std::int64_t run_id, const RunBatch& batch);
  template <class Row, class BindFn, class WhatFn>
  Status insertEach(const char* sql, std::int64_t run_id, const std::vector<Row>& rows,
                    BindFn&& bind, WhatFn&& what_of);
  Status readRun(Bound& q, RunInfo* run);
  Status loadSamples(std::int64_t run_id, io::Recording* rec);
  template <class RowFn>
  Status forEachRunRow(const char* sql, std::int64_t run_id, const char* what, RowFn&& row);
  Status loadSegments(std::int64_t run_id, io::Recording* rec);
};

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

// The queue's entry ids in order.
Status Store::Impl::queueIds(std::vector<std::int64_t>* ids) {
  Status st;
  Bound q = use("SELECT id FROM queue ORDER BY pos, id", &st);
  if (!q) return st;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) ids->push_back(q.integer(0));
  if (rc != SQLITE_DONE) return sqlError("cannot read the queue");
  return Status::Ok();
}

Status Store::Impl::runState(std::int64_t run_id, RunState* state) {
  Status st;
  Bound q = use("SELECT state FROM runs WHERE id = ?1", &st);
  if (!q) return st;
  q.bind(1, run_id);
  const int rc = q.step();
  if (rc == SQLITE_DONE) return error(runLabel(run_id) + " not found");
  if (rc != SQLITE_ROW) return sqlError("cannot read " + runLabel(run_id));
  const auto s = runStateFromName(q.text(0));
  if (!s) return error(runLabel(run_id) + " has an unknown state '" + q.text(0) + "'");
  *state = *s;
  return Status::Ok();
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

Status Store::Impl::requireAfterStored(std::int64_t run_id, const RunBatch& b) {
  const std::pair<SampleStream, std::optional<double>> firsts[] = {
      {SampleStream::kImu, b.imu.empty() ? std::nullopt : std::optional(b.imu.front().t)},
      {SampleStream::kTable, b.table.empty() ? std::nullopt : std::optional(b.table.front().t)},
      {SampleStream::kChamber,
       b.chamber.empty() ? std::nullopt : std::optional(b.chamber.front().t)}};
  for (const auto& [stream, first] : firsts) {
    if (!first) continue;
    std::optional<double> newest;
    if (auto st = lastTime(streamSql(stream).newest_t, run_id, &newest); !st.ok) return st;
    if (newest && !(*first > *newest)) {
      return error(
          runLabel(run_id) + ": batch refused: " + sampleStreamName(stream) +
          " sample 0: time does not increase past the stored t=" + std::to_string(*newest));
    }
  }
  return Status::Ok();
}

Status Store::Impl::requireRunning(std::int64_t run_id) {
  RunState state{};
  if (auto st = runState(run_id, &state); !st.ok) return st;
  if (state != RunState::kRunning) {
    return error(runLabel(run_id) + " is " + runStateName(state) + ", not running");
  }
  return Status::Ok();
}

Status Store::Impl::insertRun(const RunStart& s, RunState state, std::int64_t* run_id) {
  Status st;
  Bound q =
      use("INSERT INTO runs(plan_name, plan_toml, bench_name, imu_serial, imu_rate_hz, "
          "latitude_deg, height_m, gravity_mps2, table_kind, outer_axis_heading_deg, "
          "segments_from_file, started_unix_s, state) "
          "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)",
          &st);
  if (!q) return st;
  q.bindAll(s.plan_name, s.plan_toml, s.bench_name, s.imu_serial, s.imu_rate_hz, s.latitude_deg,
            s.height_m, s.gravity_mps2, std::string_view(tableKindName(s.table_kind)),
            s.outer_axis_heading_deg, s.segments_from_file ? 1 : 0, nowUnixS(),
            std::string_view(runStateName(state)));
  if (q.step() != SQLITE_DONE) return sqlError("cannot start a run");
  *run_id = sqlite3_last_insert_rowid(db.get());
  return Status::Ok();
}

Status Store::Impl::insertEvent(const RunEvent& e) {
  if (!nlohmann::json::accept(e.json)) {
    return error(runLabel(e.run_id) + ": event '" + e.kind + "' details are not valid JSON");
  }
  Status st;
  Bound q = use(
      "INSERT INTO events(run_id, wall_unix_s, severity, kind, json) VALUES(?1, ?2, ?3, ?4, ?5)",
      &st);
  if (!q) return st;
  q.bindAll(e.run_id, e.wall_unix_s, std::string_view(eventSeverityName(e.severity)), e.kind,
            e.json);
  if (q.step() != SQLITE_DONE) return sqlError(runLabel(e.run_id) + ": cannot add event");
  return Status::Ok();
}

// Inserts every row with `sql` (?1 is the run id; bind(q, row) binds the rest); a refusal
// names the row by what_of(row).
template <class Row, class BindFn, class WhatFn>
Status Store::Impl::insertEach(const char* sql, std::int64_t run_id, const std::vector<Row>& rows,
                               BindFn&& bind, WhatFn&& what_of) {
  Status st;
  Bound q = use(sql, &st);
  if (!q) return st;
  q.bind(1, run_id);
  for (const Row& row : rows) {
    bind(q, row);
    if (q.step() != SQLITE_DONE)
      return sqlError(runLabel(run_id) + ": cannot store " + what_of(row));
    q.rewind();
  }
  return Status::Ok();
}

Status Store::Impl::insertRows(std::int64_t run_id, const RunBatch& b) {
  auto at = [](const char* what) {
    return [what](const auto& s) { return std::string(what) + " at t=" + std::to_string(s.t); };
  };
  Status st = insertEach(
      "INSERT INTO imu_samples(run_id, t, dthx, dthy, dthz, dvx, dvy, dvz, temp_c) "
      "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
      run_id, b.imu,
      [](Bound& q, const nav::ImuSample& s) {
        q.bind(2, s.t);
        for (int i = 0; i < 3; ++i) {
          q.bind(3 + i, s.dtheta[i]);
          q.bind(6 + i, s.dvel[i]);
        }
        q.bind(9, s.temp_c);
      },
      at("IMU sample"));
  if (!st.ok) return st;
  st = insertEach(
      "INSERT INTO table_samples(run_id, t, angle0_deg, angle1_deg, angle2_deg, round_trip_s) "
      "VALUES(?1, ?2, ?3, ?4, ?5, ?6)",
      run_id, b.table,
      [&b](Bound& q, const io::TableSample& s) {
        q.bind(2, s.t);
        for (int a = 0; a < 3; ++a) q.bind(3 + a, s.angles_deg[static_cast<std::size_t>(a)]);
        const auto k = static_cast<std::size_t>(&s - b.table.data());
        // NaN (unknown) binds as NULL
        q.bind(6, k < b.table_round_trip_s.size() ? b.table_round_trip_s[k] : kNaN);
      },
      at("table sample"));
  if (!st.ok) return st;
  st = insertEach(
      "INSERT INTO chamber_samples(run_id, t, setpoint_c, temp_c) VALUES(?1, ?2, ?3, ?4)", run_id,
      b.chamber,
      [](Bound& q, const io::ChamberSample& s) {
        q.bind(2, s.t);
        q.bind(3, s.setpoint_c);
        q.bind(4, s.temp_c);
      },
      at("chamber sample"));
  if (!st.ok) return st;
  // idx continues the run's numbering: segments arrive one by one during a run.
  return insertEach(
      "INSERT INTO segments(run_id, idx, t0, t1, kind, label, recording, axis, angle_rad) "
      "VALUES(?1, (SELECT coalesce(max(idx) + 1, 0) FROM segments WHERE run_id = ?1), "
      "?2, ?3, ?4, ?5, ?6, ?7, ?8)",
      run_id, b.segments,
      [](Bound& q, const calib::Segment& s) {
        q.bind(2, s.t0);
        q.bind(3, s.t1);
        q.bind(4, std::string_view(calib::segmentKindName(s.kind)));
        q.bind(5, s.label);
        q.bind(6, s.recording ? 1 : 0);
        q.bind(7, s.axis);
        q.bind(8, s.angle);
      },
      [](const calib::Segment& s) { return "segment '" + s.label + "'"; });
}

// One row of kSelectRunsSql.
Status Store::Impl::readRun(Bound& q, RunInfo* run) {
  run->id = q.integer(0);
  RunStart& s = run->start;
  s.plan_name = q.text(1);
  s.plan_toml = q.text(2);
  s.bench_name = q.text(3);
  s.imu_serial = q.text(4);
  s.imu_rate_hz = q.real(5);
  s.latitude_deg = q.real(6);
  s.height_m = q.real(7);
  s.gravity_mps2 = q.optReal(8);
  s.table_kind =
      q.text(9) == "three-axis" ? calib::TableKind::kThreeAxis : calib::TableKind::kTwoAxis;
  s.outer_axis_heading_deg = q.optReal(10);
  s.segments_from_file = q.integer(11) != 0;
  run->started_unix_s = q.real(12);
  run->finished_unix_s = q.optReal(13);
  const auto state = runStateFromName(q.text(14));
  if (!state) return error(runLabel(run->id) + " has an unknown state '" + q.text(14) + "'");
  run->state = *state;
  run->exit_reason = q.text(15);
  return Status::Ok();
}

// Runs a "... WHERE run_id = ?1 ..." query and hands every row to row(q), which may refuse it.
template <class RowFn>
Status Store::Impl::forEachRunRow(const char* sql, std::int64_t run_id, const char* what,
                                  RowFn&& row) {
  Status st;
  Bound q = use(sql, &st);
  if (!q) return st;
  q.bind(1, run_id);
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    if (Status r = row(q); !r.ok) return r;
  }
  if (rc != SQLITE_DONE) return sqlError(runLabel(run_id) + ": cannot read " + what);
  return Status::Ok();
}

Status Store::Impl::loadSamples(std::int64_t run_id, io::Recording* rec) {
  Status st = forEachRunRow(
      "SELECT t, dthx, dthy, dthz, dvx, dvy, dvz, temp_c FROM imu_samples "
      "WHERE run_id = ?1 ORDER BY t",
      run_id, "IMU samples", [rec](Bound& q) {
        nav::ImuSample& s = rec->imu.emplace_back();
        s.t = q.real(0);
        s.dtheta = Vec3(q.real(1), q.real(2), q.real(3));
        s.dvel = Vec3(q.real(4), q.real(5), q.real(6));
        s.temp_c = q.realOrNaN(7);
        return Status::Ok();
      });
  if (!st.ok) return st;
  st = forEachRunRow(
      "SELECT t, angle0_deg, angle1_deg, angle2_deg FROM table_samples "
      "WHERE run_id = ?1 ORDER BY t",
      run_id, "table samples", [rec](Bound& q) {
        rec->table.push_back(io::TableSample{q.real(0), {q.real(1), q.real(2), q.real(3)}});
        return Status::Ok();
      });
  if (!st.ok) return st;
  return forEachRunRow(
      "SELECT t, setpoint_c, temp_c FROM chamber_samples WHERE run_id = ?1 ORDER BY t", run_id,
      "chamber samples", [rec](Bound& q) {
        rec->chamber.push_back(io::ChamberSample{q.real(0), q.real(1), q.real(2)});
        return Status::Ok();
      });
}

Status Store::Impl::loadSegments(std::int64_t run_id, io::Recording* rec) {
  return forEachRunRow(
      "SELECT t0, t1, kind, label, recording, axis, angle_rad FROM segments "
      "WHERE run_id = ?1 ORDER BY idx",
      run_id, "segments", [this, run_id, rec](Bound& q) {
        calib::Segment& s = rec->segments.emplace_back();
        s.t0 = q.real(0);
        s.t1 = q.real(1);
        const auto kind = segmentKindFromName(q.text(2));
        if (!kind) return error(runLabel(run_id) + ": unknown segment kind '" + q.text(2) + "'");
        s.kind = *kind;
        s.label = q.text(3);
        s.recording = q.integer(4) != 0;
        s.axis = static_cast<int>(q.integer(5));
        s.angle = q.real(6);
        return Status::Ok();
      });
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

bool runResumable(RunState state) {
  return state == RunState::kInterrupted || state == RunState::kAborted ||
         state == RunState::kFaulted;
}

constexpr io::Named<RunState> kRunStateNames[] = {
    {RunState::kRunning, "running"},         {RunState::kFinished, "finished"},
    {RunState::kAborted, "aborted"},         {RunState::kFaulted, "faulted"},
    {RunState::kInterrupted, "interrupted"},
};

const char* runStateName(RunState state) {
  return io::nameOf(kRunStateNames, state, "running");
}

std::optional<RunState> runStateFromName(std::string_view name) {
  return io::valueOf(kRunStateNames, name);
}

constexpr io::Named<EventSeverity> kEventSeverityNames[] = {
    {EventSeverity::kInfo, "info"},
    {EventSeverity::kWarning, "warning"},
    {EventSeverity::kError, "error"},
};

const char* eventSeverityName(EventSeverity severity) {
  return io::nameOf(kEventSeverityNames, severity, "info");
}

bool RunStart::IsValid(std::string* why) const {
  auto fail = [&](const char* w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!(imu_rate_hz > 0.0) || !std::isfinite(imu_rate_hz))
    return fail("imu_rate_hz must be positive and finite");
  if (!(std::abs(latitude_deg) <= 90.0)) return fail("latitude_deg must be within [-90, 90]");
  if (!std::isfinite(height_m)) return fail("height_m must be finite");
  if (gravity_mps2 && (!(*gravity_mps2 > 0.0) || !std::isfinite(*gravity_mps2)))
    return fail("gravity_mps2 must be positive and finite");
  if (outer_axis_heading_deg && table_kind != calib::TableKind::kTwoAxis)
    return fail("outer_axis_heading_deg applies to two-axis tables only");
  if (outer_axis_heading_deg && !std::isfinite(*outer_axis_heading_deg))
    return fail("outer_axis_heading_deg must be finite");
  return true;
}

RunStart runStartFromRecording(const io::Recording& rec) {
  RunStart s;
  s.imu_serial = rec.imu_serial;
  s.imu_rate_hz = rec.imu_rate_hz;
  s.latitude_deg = rec.latitude_deg;
  s.height_m = rec.height_m;
  s.gravity_mps2 = rec.gravity_mps2;
  s.table_kind = rec.table_kind;
  s.outer_axis_heading_deg = rec.outer_axis_heading_deg;
  s.segments_from_file = rec.segments_from_file;
  return s;
}

void RunBatch::clear() {
  imu.clear();
  table.clear();
  table_round_trip_s.clear();
  chamber.clear();
  segments.clear();
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

RunIdResult Store::beginRun(const RunStart& start) {
  RunIdResult r;
  std::string why;
  if (!start.IsValid(&why)) {
    r.status = impl_->error("cannot start a run: " + why);
    return r;
  }
  r.status = impl_->insertRun(start, RunState::kRunning, &r.value);
  return r;
}

Status Store::finishRun(std::int64_t run_id, RunState state, const std::string& reason) {
  if (state == RunState::kRunning) {
    return impl_->error("cannot finish " + runLabel(run_id) + " in state running");
  }
  return impl_->transaction("cannot finish " + runLabel(run_id), [&]() {
    if (auto st = impl_->requireRunning(run_id); !st.ok) return st;
    Status st;
    Bound q = impl_->use(
        "UPDATE runs SET state = ?2, exit_reason = ?3, finished_unix_s = ?4 WHERE id = ?1", &st);
    if (!q) return st;
    const double now = nowUnixS();
    q.bindAll(run_id, std::string_view(runStateName(state)), reason, now);
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot finish " + runLabel(run_id));
    const nlohmann::json details = {{"state", runStateName(state)}, {"reason", reason}};
    return impl_->insertEvent({run_id, now, endSeverity(state), "run-end", details.dump()});
  });
}

CountResult Store::markInterruptedRuns() {
  CountResult r;
  r.status = impl_->transaction("cannot mark interrupted runs", [&]() {
    std::vector<std::int64_t> ids;
    Status st;
    {
      Bound q = impl_->use("SELECT id FROM runs WHERE state = 'running' ORDER BY id", &st);
      if (!q) return st;
      int rc;
      while ((rc = q.step()) == SQLITE_ROW) ids.push_back(q.integer(0));
      if (rc != SQLITE_DONE) return impl_->sqlError("cannot list running runs");
    }
    for (const std::int64_t id : ids) {
      std::optional<double> last_t;
      if (st = impl_->lastTime(kLastImuTSql, id, &last_t); !st.ok) return st;
      std::string reason = "the daemon stopped while the run was active (found at start-up)";
      reason += last_t ? "; last stored sample at t = " + std::to_string(*last_t) + " s"
                       : "; no sample stored";
      Bound q =
          impl_->use("UPDATE runs SET state = 'interrupted', exit_reason = ?2 WHERE id = ?1", &st);
      if (!q) return st;
      q.bind(1, id);
      q.bind(2, reason);
      if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot mark " + runLabel(id));
      nlohmann::json details = {{"reason", reason}};
      if (last_t) details["last_sample_t"] = *last_t;
      st = impl_->insertEvent(
          {id, nowUnixS(), EventSeverity::kWarning, "interrupted", details.dump()});
      if (!st.ok) return st;
    }
    r.value = static_cast<int>(ids.size());
    return Status::Ok();
  });
  if (!r.status.ok) r.value = 0;
  return r;
}

Status Store::resumeRun(std::int64_t run_id) {
  return impl_->transaction("cannot resume " + runLabel(run_id), [&]() {
    RunState state{};
    if (auto st = impl_->runState(run_id, &state); !st.ok) return st;
    if (!runResumable(state)) {
      return impl_->error(runLabel(run_id) + " is " + runStateName(state) +
                          "; only an interrupted, aborted or faulted run can be resumed");
    }
    Status st;
    Bound q = impl_->use(
        "UPDATE runs SET state = 'running', exit_reason = '', finished_unix_s = NULL "
        "WHERE id = ?1",
        &st);
    if (!q) return st;
    q.bind(1, run_id);
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot resume " + runLabel(run_id));
    return impl_->insertEvent({run_id, nowUnixS(), EventSeverity::kInfo, "resumed", "{}"});
  });
}

ResumePoint Store::resumePoint(std::int64_t run_id) {
  ResumePoint p;
  RunState state{};
  if (p.status = impl_->runState(run_id, &state); !p.status.ok) return p;
  std::optional<double> step;
  for (const auto& [sql, out] :
       {std::pair{kLastImuTSql, &p.last_imu_t},
        std::pair{"SELECT max(t) FROM table_samples WHERE run_id = ?1", &p.last_table_t},
        std::pair{"SELECT max(t) FROM chamber_samples WHERE run_id = ?1", &p.last_chamber_t},
        std::pair{"SELECT max(t1) FROM segments WHERE run_id = ?1", &p.last_segment_t1},
        // The newest checkpoint, not the largest step: a resumed temperature point re-runs
        // steps that had finished before (Store::discardSegmentsFrom).
        std::pair{"SELECT json_extract(json, '$.step') FROM events "
                  "WHERE run_id = ?1 AND kind = 'step_finished' ORDER BY id DESC LIMIT 1",
                  &step}}) {
    if (p.status = impl_->lastTime(sql, run_id, out); !p.status.ok) return p;
  }
  if (step) p.last_finished_step = static_cast<int>(*step);
  return p;
}

CountResult Store::discardSegmentsFrom(std::int64_t run_id, const std::string& label) {
  CountResult r;
  r.status = impl_->transaction("cannot discard segments of " + runLabel(run_id), [&]() {
    Status st;
    std::optional<double> from;
    {
      Bound q = impl_->use("SELECT max(idx) FROM segments WHERE run_id = ?1 AND label = ?2", &st);
      if (!q) return st;
      q.bind(1, run_id);
      q.bind(2, std::string_view(label));
      if (q.step() != SQLITE_ROW) return impl_->sqlError("cannot read " + runLabel(run_id));
      from = q.optReal(0);
    }
    if (!from) return Status::Ok();  // the step never finished: nothing of it is stored
    Bound del = impl_->use("DELETE FROM segments WHERE run_id = ?1 AND idx >= ?2", &st);
    if (!del) return st;
    del.bind(1, run_id);
    del.bind(2, static_cast<std::int64_t>(*from));
    if (del.step() != SQLITE_DONE) return impl_->sqlError("cannot discard segments");
    r.value = sqlite3_changes(impl_->db.get());
    const nlohmann::json details = {{"from_label", label}, {"segments", r.value}};
    return impl_->insertEvent(
        {run_id, nowUnixS(), EventSeverity::kInfo, "segments_discarded", details.dump()});
  });
  if (!r.status.ok) r.value = 0;
  return r;
}

CountResult Store::discardTrailingSegments(std::int64_t run_id,
                                           const std::vector<std::string>& labels) {
  CountResult r;
  r.value = 0;
  r.status = impl_->transaction("cannot discard segments of " + runLabel(run_id), [&]() {
    Status st;
    std::vector<std::string> gone;
    for (auto label = labels.rbegin(); label != labels.rend(); ++label) {
      std::int64_t idx = 0;
      {
        Bound q = impl_->use(
            "SELECT idx, label FROM segments WHERE run_id = ?1 ORDER BY idx DESC LIMIT 1", &st);
        if (!q) return st;
        q.bind(1, run_id);
        const int rc = q.step();
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) return impl_->sqlError("cannot read " + runLabel(run_id));
        if (q.text(1) != *label) break;
        idx = q.integer(0);
      }
      Bound del = impl_->use("DELETE FROM segments WHERE run_id = ?1 AND idx = ?2", &st);
      if (!del) return st;
      del.bind(1, run_id);
      del.bind(2, idx);
      if (del.step() != SQLITE_DONE) return impl_->sqlError("cannot discard segments");
      gone.push_back(*label);
    }
    r.value = static_cast<int>(gone.size());
    if (gone.empty()) return Status::Ok();
    const nlohmann::json details = {{"labels", gone}, {"segments", r.value}};
    return impl_->insertEvent(
        {run_id, nowUnixS(), EventSeverity::kInfo, "segments_discarded", details.dump()});
  });
  if (!r.status.ok) r.value = 0;
  return r;
}

RunListResult Store::listRuns() {
  RunListResult r;
  Bound q = impl_->use(kSelectRunsSql, &r.status);
  if (!q) return r;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    if (r.status = impl_->readRun(q, &r.value.emplace_back()); !r.status.ok) return r;
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot list runs");
  return r;
}

RunInfoResult Store::runInfo(std::int64_t run_id) {
  RunInfoResult r;
  Bound q = impl_->use(kSelectRunsSql, &r.status);
  if (!q) return r;
  q.bind(1, run_id);
  const int rc = q.step();
  if (rc == SQLITE_DONE) {
    r.status = impl_->error(runLabel(run_id) + " not found");
  } else if (rc != SQLITE_ROW) {
    r.status = impl_->sqlError("cannot read " + runLabel(run_id));
  } else {
    r.status = impl_->readRun(q, &r.value);
  }
  return r;
}

Status Store::appendBatch(std::int64_t run_id, const RunBatch& batch) {
  if (auto st = checkBatch(batch); !st.ok) {
    return impl_->error(runLabel(run_id) + ": batch refused: " + st.message);
  }
  return impl_->transaction("cannot store samples of " + runLabel(run_id), [&]() {
    if (auto st = impl_->requireRunning(run_id); !st.ok) return st;
    if (auto st = impl_->requireAfterStored(run_id, batch); !st.ok) return st;
    return impl_->insertRows(run_id, batch);
  });
}

Status Store::addEvent(const RunEvent& event) {
  return impl_->transaction("cannot add event", [&]() {
    RunState state{};
    if (auto st = impl_->runState(event.run_id, &state); !st.ok) return st;
    return impl_->insertEvent(event);
  });
}

EventListResult Store::events(std::int64_t run_id) {
  EventListResult r;
  RunState state{};
  if (r.status = impl_->runState(run_id, &state); !r.status.ok) return r;
  Bound q = impl_->use(
      "SELECT wall_unix_s, severity, kind, json FROM events WHERE run_id = ?1 ORDER BY id",
      &r.status);
  if (!q) return r;
  q.bind(1, run_id);
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    const EventSeverity severity =
        io::valueOf(kEventSeverityNames, q.text(1)).value_or(EventSeverity::kInfo);
    r.value.push_back({run_id, q.real(0), severity, q.text(2), q.text(3)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read events of " + runLabel(run_id));
  return r;
}

RunIdResult Store::importRecording(const RunStart& start, const io::Recording& rec) {
  RunIdResult r;
  std::string why;
  if (!start.IsValid(&why)) {
    r.status = impl_->error("cannot import recording: " + why);
    return r;
  }
  RunBatch batch{rec.imu, rec.table, {}, rec.chamber, rec.segments};  // round trips unknown
  if (auto st = checkBatch(batch); !st.ok) {
    r.status = impl_->error("cannot import recording: " + st.message);
    return r;
  }
  r.status = impl_->transaction("cannot import recording", [&]() {
    if (auto st = impl_->insertRun(start, RunState::kRunning, &r.value); !st.ok) return st;
    if (auto st = impl_->insertRows(r.value, batch); !st.ok) return st;
    Status st;
    Bound q = impl_->use(
        "UPDATE runs SET state = 'finished', exit_reason = 'imported', "
        "finished_unix_s = started_unix_s WHERE id = ?1",
        &st);
    if (!q) return st;
    q.bind(1, r.value);
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot finish the imported run");
    return Status::Ok();
  });
  if (!r.status.ok) r.value = 0;
  return r;
}

io::RecordingReadResult Store::loadRecording(std::int64_t run_id) {
  io::RecordingReadResult r;
  const RunInfoResult info = runInfo(run_id);
  if (!info.status.ok) {
    r.status = info.status;
    return r;
  }
  const RunStart& s = info.value.start;
  io::Recording& rec = r.value;
  rec.latitude_deg = s.latitude_deg;
  rec.height_m = s.height_m;
  rec.gravity_mps2 = s.gravity_mps2;
  rec.imu_serial = s.imu_serial;
  rec.imu_rate_hz = s.imu_rate_hz;
  rec.table_kind = s.table_kind;
  rec.outer_axis_heading_deg = s.outer_axis_heading_deg;
  rec.segments_from_file = s.segments_from_file;
  // A read transaction around the reads: one consistent snapshot while the daemon writes.
  Status st = impl_->execSql("BEGIN", "cannot read " + runLabel(run_id));
  if (st.ok) st = impl_->loadSamples(run_id, &rec);
  if (st.ok) st = impl_->loadSegments(run_id, &rec);
  sqlite3_exec(impl_->db.get(), "COMMIT", nullptr, nullptr, nullptr);
  if (!st.ok) {
    r.status = st;
    r.value = io::Recording{};
  }
  return r;
}

TableRoundTripsResult Store::tableRoundTrips(std::int64_t run_id) {
  TableRoundTripsResult r;
  if (auto info = runInfo(run_id); !info.status.ok) {
    r.status = info.status;
    return r;
  }
  r.status =
      impl_->forEachRunRow("SELECT t, round_trip_s FROM table_samples WHERE run_id = ?1 ORDER BY t",
                           run_id, "table round trips", [&r](Bound& q) {
                             TableRoundTrip& row = r.value.emplace_back();
                             row.t = q.real(0);
                             const double rt = q.realOrNaN(1);
                             if (!std::isnan(rt)) row.round_trip_s = rt;
                             return Status::Ok();
                           });
  if (!r.status.ok) r.value.clear();
  return r;
}

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

QueueAddResult Store::queueAdd(const QueueEntry& entry) {
  QueueAddResult r;
  r.status = impl_->transaction("cannot queue plan '" + entry.plan_name + "'", [&]() {
    Status st;
    Bound q = impl_->use(
        "INSERT INTO queue(pos, plan_name, source, plan_toml, label, added_unix_s) "
        "VALUES((SELECT coalesce(max(pos), 0) + 1 FROM queue), ?1, ?2, ?3, ?4, ?5)",
        &st);
    if (!q) return st;
    q.bindAll(entry.plan_name, entry.source, entry.plan_toml, entry.label, nowUnixS());
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot queue the plan");
    r.value.entry_id = sqlite3_last_insert_rowid(impl_->db.get());
    std::int64_t count = 0;
    st = impl_->queryInt("SELECT count(*) FROM queue", "cannot count the queue", &count);
    r.value.position = static_cast<int>(count);
    return st;
  });
  if (!r.status.ok) r.value.entry_id = 0;
  return r;
}

QueueListResult Store::queueList() {
  QueueListResult r;
  Bound q = impl_->use(
      "SELECT id, plan_name, source, plan_toml, label, added_unix_s FROM queue ORDER BY pos, id",
      &r.status);
  if (!q) return r;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.push_back({q.integer(0), q.text(1), q.text(2), q.text(3), q.text(4), q.real(5)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read the queue");
  return r;
}

Status Store::queueMove(std::int64_t entry_id, int position) {
  const std::string what = "queue entry " + std::to_string(entry_id);
  return impl_->transaction("cannot move " + what, [&]() {
    std::vector<std::int64_t> ids;
    if (auto st = impl_->queueIds(&ids); !st.ok) return st;
    const auto it = std::find(ids.begin(), ids.end(), entry_id);
    if (it == ids.end()) return impl_->error(what + " not found");
    if (position < 1 || static_cast<std::size_t>(position) > ids.size())
      return impl_->error("position " + std::to_string(position) + " is outside 1.." +
                          std::to_string(ids.size()));
    ids.erase(it);
    ids.insert(ids.begin() + (position - 1), entry_id);
    Status st;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      Bound q = impl_->use("UPDATE queue SET pos = ?2 WHERE id = ?1", &st);
      if (!q) return st;
      q.bind(1, ids[i]);
      q.bind(2, static_cast<std::int64_t>(i + 1));
      if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot move " + what);
    }
    return Status::Ok();
  });
}

Status Store::queueRemove(std::int64_t entry_id) {
  const std::string what = "queue entry " + std::to_string(entry_id);
  Status st;
  Bound q = impl_->use("DELETE FROM queue WHERE id = ?1", &st);
  if (!q) return st;
  q.bind(1, entry_id);
  if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot remove " + what);
  if (sqlite3_changes(impl_->db.get()) == 0) return impl_->error(what + " not found");
  return Status::Ok();
}

Status Store::enableOutbox() {
  return impl_->transaction("cannot enable the lab outbox", [&]() {
    std::int64_t enabled = 0;
    if (auto st = impl_->queryInt("SELECT count(*) FROM lab_outbox_enabled",
                                  "cannot read the lab outbox", &enabled);
        !st.ok || enabled != 0) {
      return st;
    }
    return impl_->execSql(kOutboxBackfillSql, "cannot fill the lab outbox");
  });
}

OutboxListResult Store::outboxPeek(std::size_t limit) {
  OutboxListResult r;
  Bound q = impl_->use(
      "SELECT seq, run_id, item, kind, op, payload FROM lab_outbox ORDER BY seq LIMIT ?1",
      &r.status);
  if (!q) return r;
  q.bind(1, static_cast<std::int64_t>(limit));
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.push_back(
        {q.integer(0), q.integer(1), q.text(2), q.text(3), q.text(4) == "delete", q.text(5)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read the lab outbox");
  return r;
}

Status Store::outboxAck(std::int64_t up_to_seq) {
  Status st;
  Bound q = impl_->use("DELETE FROM lab_outbox WHERE seq <= ?1", &st);
  if (!q) return st;
  q.bind(1, up_to_seq);
  if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot acknowledge the lab outbox");
  return Status::Ok();
}

CountResult Store::outboxBacklog() {
  CountResult r;
  std::int64_t n = 0;
  r.status = impl_->queryInt("SELECT count(*) FROM lab_outbox", "cannot count the lab outbox", &n);
  r.value = static_cast<int>(n);
  return r;
}

const char* sampleStreamName(SampleStream stream) {
  return streamSql(stream).name;
}

std::span<const char* const> sampleColumns(SampleStream stream) {
  return streamSql(stream).columns;
}

SampleTailsResult Store::sampleTails() {
  SampleTailsResult r;
  // One index seek per run and stream (a GROUP BY would scan every row).
  Bound q = impl_->use(
      "SELECT id, (SELECT max(t) FROM imu_samples WHERE run_id = runs.id), "
      "(SELECT max(t) FROM table_samples WHERE run_id = runs.id), "
      "(SELECT max(t) FROM chamber_samples WHERE run_id = runs.id) FROM runs ORDER BY id",
      &r.status);
  if (!q) return r;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    for (int k = 0; k < 3; ++k) {
      if (!q.isNull(1 + k)) {
        r.value.push_back({q.integer(0), kSampleStreams[k], q.real(1 + k)});
      }
    }
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read the runs' newest samples");
  return r;
}

SampleRowsResult Store::readSamples(std::int64_t run_id, SampleStream stream,
                                    std::optional<double> after_t, std::size_t limit) {
  SampleRowsResult r;
  const StreamSql& sql = streamSql(stream);
  r.value.stream = stream;
  r.value.columns = sql.columns.size();
  Bound q = impl_->use(sql.read, &r.status);
  if (!q) return r;
  q.bindAll(run_id, after_t.value_or(-std::numeric_limits<double>::infinity()),
            static_cast<std::int64_t>(limit));
  r.value.t.reserve(limit);
  r.value.values.reserve(limit * sql.columns.size());
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.t.push_back(q.real(0));
    for (std::size_t c = 0; c < sql.columns.size(); ++c) {
      r.value.values.push_back(q.realOrNaN(static_cast<int>(c) + 1));
    }
  }
  if (rc != SQLITE_DONE) {
    r.status =
        impl_->sqlError("cannot read " + std::string(sql.name) + " samples of " + runLabel(run_id));
  }
  return r;
}

SampleCountResult Store::countSamples(std::int64_t run_id, SampleStream stream,
                                      std::optional<double> after_t) {
  SampleCountResult r;
  const StreamSql& sql = streamSql(stream);
  Bound q = impl_->use(sql.count, &r.status);
  if (!q) return r;
  q.bindAll(run_id, after_t.value_or(-std::numeric_limits<double>::infinity()));
  if (q.step() != SQLITE_ROW) {
    r.status = impl_->sqlError("cannot count " + std::string(sql.name) + " samples of " +
                               runLabel(run_id));
  } else {
    r.value = q.integer(0);
  }
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

// ---------------------------------------------------------------------------------------
// RunWriter

RunWriter::RunWriter(Store& store, std::int64_t run_id) : store_(&store), run_id_(run_id) {}

RunWriter::RunWriter(Store& store, std::int64_t run_id, const ResumePoint& point)
    : store_(&store),
      run_id_(run_id),
      last_imu_t_(point.last_imu_t),
      last_table_t_(point.last_table_t),
      last_chamber_t_(point.last_chamber_t),
      last_segment_t1_(point.last_segment_t1) {}

RunWriter::~RunWriter() {
  (void)flush();
}

template <class Row>
Status RunWriter::appendRows(const char* what, std::span<const Row> rows,
                             std::optional<double>* last_t, std::vector<Row>* buffer) {
  if (rows.empty()) return Status::Ok();
  if (auto st = checkRows(what, rows, *last_t); !st.ok) {
    return Status::Error(store_->path() + ": " + runLabel(run_id_) + ": " + st.message);
  }
  buffer->insert(buffer->end(), rows.begin(), rows.end());
  *last_t = rows.back().t;
  return buffered(rows.front().t, rows.back().t);
}

Status RunWriter::appendImu(std::span<const nav::ImuSample> samples) {
  return appendRows("IMU sample", samples, &last_imu_t_, &buffer_.imu);
}

Status RunWriter::appendTable(std::span<const io::TableSample> samples,
                              std::span<const double> round_trip_s) {
  if (auto st = checkRoundTrips(round_trip_s, samples.size()); !st.ok) {
    return Status::Error(store_->path() + ": " + runLabel(run_id_) + ": " + st.message);
  }
  // Buffered first: appendRows may flush. One per buffered table row (NaN: unknown).
  const std::size_t before = buffer_.table.size();
  std::vector<double>& trips = buffer_.table_round_trip_s;
  trips.resize(before, kNaN);
  if (round_trip_s.empty()) {
    trips.resize(before + samples.size(), kNaN);
  } else {
    trips.insert(trips.end(), round_trip_s.begin(), round_trip_s.end());
  }
  Status st = appendRows("table sample", samples, &last_table_t_, &buffer_.table);
  if (!st.ok && buffer_.table.size() == before) trips.resize(before);  // refused: not buffered
  return st;
}

Status RunWriter::appendChamber(std::span<const io::ChamberSample> samples) {
  return appendRows("chamber sample", samples, &last_chamber_t_, &buffer_.chamber);
}

Status RunWriter::appendSegment(const calib::Segment& segment) {
  if (auto st = checkSegments(std::span(&segment, 1), last_segment_t1_); !st.ok) {
    return Status::Error(store_->path() + ": " + runLabel(run_id_) + ": " + st.message);
  }
  buffer_.segments.push_back(segment);
  last_segment_t1_ = segment.t1;
  // A segment is appended when it ends; it is as old as its end time.
  return buffered(segment.t1, segment.t1);
}

Status RunWriter::buffered(double oldest_new_t, double newest_t) {
  if (!oldest_buffered_t_ || oldest_new_t < *oldest_buffered_t_) oldest_buffered_t_ = oldest_new_t;
  if (buffer_.rows() >= store_->options().max_unflushed_rows) return flush();
  return flushIfDue(newest_t);
}

Status RunWriter::flushIfDue(double now_t) {
  if (oldest_buffered_t_ && now_t - *oldest_buffered_t_ >= store_->options().max_unflushed_s) {
    return flush();
  }
  return Status::Ok();
}

Status RunWriter::flush() {
  if (buffer_.rows() == 0) return Status::Ok();
  // On failure the rows stay buffered, so a later flush can retry them.
  if (auto st = store_->appendBatch(run_id_, buffer_); !st.ok) return st;
  buffer_.clear();
  oldest_buffered_t_.reset();
  return Status::Ok();
}

}  // namespace imubench::daemon
