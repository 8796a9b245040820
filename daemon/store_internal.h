// Internals shared by the parts of the run store (daemon/store.h): the SQLite handles, the
// cached-statement binder, Store::Impl (the connection and its SQL helpers) and a few helpers.
// Not a public API: only daemon/store.cpp and daemon/store_*.cpp include it. Which part holds
// what is listed at the top of daemon/store.cpp.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "daemon/store.h"

namespace imubench::daemon {
namespace store_internal {

// The newest stored IMU sample of run ?1 (NULL: none). An inline variable: one object, so one
// cached statement, in every part.
inline constexpr char kLastImuTSql[] = "SELECT max(t) FROM imu_samples WHERE run_id = ?1";

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
// The stream's SQL (store_sample_reads.cpp).
const StreamSql& streamSql(SampleStream stream);

// Now on the wall clock, s since the Unix epoch.
double nowUnixS();
// "run N", as messages name a run.
std::string runLabel(std::int64_t run_id);

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

}  // namespace store_internal

// ---------------------------------------------------------------------------------------
// Store::Impl: the connection, its cached statements and the SQL helpers

struct Store::Impl {
  std::string path;
  StoreOptions options;
  store_internal::DbPtr db;
  std::unordered_map<const char*, store_internal::StmtPtr> statements;  // keyed by the SQL literal

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
  store_internal::Bound use(const char* sql, Status* st) {
    auto& slot = statements[sql];
    if (!slot) {
      sqlite3_stmt* s = nullptr;
      if (sqlite3_prepare_v3(db.get(), sql, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) !=
          SQLITE_OK) {
        *st = sqlError("cannot prepare statement");
        statements.erase(sql);
        return store_internal::Bound(nullptr);
      }
      slot.reset(s);
    }
    return store_internal::Bound(slot.get());
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
    store_internal::Bound q = use(sql, &st);
    if (!q) return st;
    if (q.step() != SQLITE_ROW) return sqlError(what);
    *out = q.integer(0);
    return Status::Ok();
  }

  // store.cpp: opening, the schema, the end of a stream
  Status openConnection();
  Status checkSchemaVersion(std::int64_t* version);
  Status configure();
  Status createSchemaIfNew();
  Status migrateSchema();
  // A one-value query on run ?1 (a max(...)); NULL leaves *out unset.
  Status lastTime(const char* sql, std::int64_t run_id, std::optional<double>* out);

  // store_runs.cpp
  Status runState(std::int64_t run_id, RunState* state);
  Status requireRunning(std::int64_t run_id);
  Status insertRun(const RunStart& start, RunState state, std::int64_t* run_id);
  Status insertEvent(const RunEvent& event);
  Status readRun(store_internal::Bound& q, RunInfo* run);

  // store_samples.cpp
  // Each stream's first row of `batch` comes after the stream's newest stored row.
  Status requireAfterStored(std::int64_t run_id, const RunBatch& batch);
  Status insertRows(std::int64_t run_id, const RunBatch& batch);
  template <class Row, class BindFn, class WhatFn>
  Status insertEach(const char* sql, std::int64_t run_id, const std::vector<Row>& rows,
                    BindFn&& bind, WhatFn&& what_of);

  // store_sample_reads.cpp
  Status loadSamples(std::int64_t run_id, io::Recording* rec);
  template <class RowFn>
  Status forEachRunRow(const char* sql, std::int64_t run_id, const char* what, RowFn&& row);
  Status loadSegments(std::int64_t run_id, io::Recording* rec);

  // store_queue.cpp
  Status queueIds(std::vector<std::int64_t>* ids);
};

}  // namespace imubench::daemon
