// The lab mirror against a real PostgreSQL server (issue 30): every item of a bench's SQLite
// store arrives exactly once (counts and checksums against the store's own lab_item_* views)
// through an outage, a kill -9 of the shipper, a wrong password and a read-only role; hostile
// text arrives verbatim. Each test starts its own throwaway cluster (lab_cluster.h).
#include <endian.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "daemon/store.h"
#include "lab/lab_reader.h"
#include "lab/shipper.h"
#include "tests/lab/lab_cluster.h"

namespace imubench::lab {
namespace {

using daemon::Store;
using testing::LabCluster;
using Key = std::pair<std::int64_t, std::string>;
using Items = std::map<Key, nlohmann::json>;

constexpr const char* kHostile[] = {
    "'); DROP TABLE lab.items; --",
    "x' OR '1'='1",
    "\"; DELETE FROM lab.items WHERE true; --",
    "$1::jsonb); TRUNCATE lab.items; --",
    "back\\slash \\x00 \\\\ 'quote' \"dq\" \t tab",
    "Robert'); DROP ROLE lab_writer;--  \xc3\xa9\xe6\xbc\xa2\xf0\x9f\x98\x80",
};

double now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A bench's work: runs with step events, segments, results, a finish; a queued plan that
// leaves the queue; one discarded segment (a delete in the lab).
void fillBench(Store& store, int runs, int events_per_run, const std::string& serial,
               const std::string& label = "step") {
  for (int r = 0; r < runs; ++r) {
    daemon::RunStart start;
    start.plan_name = label + " plan";
    start.plan_toml = "[plan]\nname = \"" + label + "\"\n";
    start.bench_name = label;
    start.imu_serial = serial;
    start.imu_rate_hz = 200.0;
    start.latitude_deg = 48.1;
    const auto id = store.beginRun(start);
    ASSERT_TRUE(id.ok()) << id.status.message;
    for (int e = 0; e < events_per_run; ++e) {
      const nlohmann::json details = {{"step", e}, {"label", label}, {"value", 0.1 * e}};
      ASSERT_TRUE(store
                      .addEvent({id.value, now(), daemon::EventSeverity::kInfo, "step_finished",
                                 details.dump()})
                      .ok);
    }
    daemon::RunBatch batch;
    for (int k = 0; k < 3; ++k) {
      calib::Segment s;
      s.t0 = 10.0 * k;
      s.t1 = 10.0 * k + 5.0;
      s.label = label + " " + std::to_string(k);
      batch.segments.push_back(s);
    }
    ASSERT_TRUE(store.appendBatch(id.value, batch).ok);
    ASSERT_TRUE(store.discardTrailingSegments(id.value, {label + " 2"}).ok());
    const nlohmann::json coeffs = {{"serial", serial}, {"label", label}, {"bias", {1e-5, -2.5, 3}}};
    ASSERT_TRUE(store.storeResult(id.value, serial, 25.0 + r, "coefficients", coeffs.dump()).ok());
    ASSERT_TRUE(store.finishRun(id.value, daemon::RunState::kFinished, label).ok);
  }
  daemon::QueueEntry q;
  q.plan_name = label;
  q.source = label;
  q.plan_toml = "[plan]";
  q.label = label;
  const auto place = store.queueAdd(q);
  ASSERT_TRUE(place.ok());
  ASSERT_TRUE(store.queueRemove(place.value.entry_id).ok);
}

// What the bench's SQLite holds now, as the lab must see it (queue history aside: the queue
// table keeps only what is waiting, the lab keeps its history).
Items sqliteItems(const std::string& path) {
  Items out;
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  const char* sql =
      "SELECT run_id, item, payload FROM lab_item_runs UNION ALL "
      "SELECT run_id, item, payload FROM lab_item_events UNION ALL "
      "SELECT run_id, item, payload FROM lab_item_results UNION ALL "
      "SELECT run_id, item, payload FROM lab_item_segments";
  EXPECT_EQ(sqlite3_prepare_v2(db, sql, -1, &q, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  while (sqlite3_step(q) == SQLITE_ROW) {
    const Key k{sqlite3_column_int64(q, 0),
                reinterpret_cast<const char*>(sqlite3_column_text(q, 1))};
    out[k] = nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(q, 2)));
  }
  sqlite3_finalize(q);
  sqlite3_close(db);
  return out;
}

Items labItems(const LabCluster& cluster, const std::string& bench, const char* kinds) {
  Items out;
  PgConn c(PQconnectdb(cluster.adminConninfo().c_str()));
  const std::string sql =
      "SELECT run_id, item, payload::text FROM lab.items WHERE bench_id = $1 "
      "AND kind " +
      std::string(kinds);
  const char* params[] = {bench.c_str()};
  PgResult r(PQexecParams(c.get(), sql.c_str(), 1, nullptr, params, nullptr, nullptr, 0));
  EXPECT_EQ(PQresultStatus(r.get()), PGRES_TUPLES_OK) << PQresultErrorMessage(r.get());
  for (int i = 0; i < PQntuples(r.get()); ++i) {
    const Key k{std::atoll(PQgetvalue(r.get(), i, 0)), PQgetvalue(r.get(), i, 1)};
    EXPECT_EQ(out.count(k), 0U) << "duplicate " << k.second;
    out[k] = nlohmann::json::parse(PQgetvalue(r.get(), i, 2));
  }
  return out;
}

// FNV-1a over the items in key order (payloads in nlohmann's canonical dump).
std::uint64_t checksum(const Items& items) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const auto& [k, v] : items) {
    for (const char ch : std::to_string(k.first) + "|" + k.second + "|" + v.dump() + "\n") {
      h = (h ^ static_cast<unsigned char>(ch)) * 1099511628211ULL;
    }
  }
  return h;
}

// Every item once, equal payloads: counts, checksums, and the first difference by name.
void expectMirrored(const LabCluster& cluster, const std::string& bench,
                    const std::string& store_path) {
  const Items want = sqliteItems(store_path);
  const Items got = labItems(cluster, bench, "<> 'queue'");
  ASSERT_FALSE(want.empty());
  EXPECT_EQ(got.size(), want.size());
  EXPECT_EQ(checksum(got), checksum(want));
  for (const auto& [k, v] : want) {
    const auto it = got.find(k);
    if (it == got.end()) {
      ADD_FAILURE() << "missing in the lab: run " << k.first << " " << k.second;
      return;
    }
    if (it->second != v) {
      ADD_FAILURE() << "differs: run " << k.first << " " << k.second << ": lab "
                    << it->second.dump() << " vs SQLite " << v.dump();
      return;
    }
  }
}

int backlog(Store& s) {
  const auto b = s.outboxBacklog();
  EXPECT_TRUE(b.ok()) << b.status.message;
  return b.value;
}

bool waitFor(const std::function<bool()>& pred, double timeout_s) {
  const double end = now() + timeout_s;
  while (now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return pred();
}

ShipperOptions fastRetry() {
  ShipperOptions o;
  o.retry_min_s = 0.1;
  o.retry_max_s = 1.0;
  o.idle_poll_s = 0.05;
  return o;
}

class LabMirrorTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(cluster_.started()); }
  std::unique_ptr<Store> openStore(const std::string& name) {
    auto s = Store::open(cluster_.root() + "/" + name + ".db");
    EXPECT_TRUE(s.ok()) << s.status.message;
    return std::move(s.value);
  }
  LabCluster cluster_;
};

TEST_F(LabMirrorTest, BackfillAndLaterChangesArriveOnceWithEqualPayloads) {
  auto store = openStore("a");
  fillBench(*store, 3, 20, "SN-A1");  // before the outbox exists: the backfill carries it
  ASSERT_TRUE(store->enableOutbox().ok);
  ASSERT_TRUE(store->enableOutbox().ok);  // idempotent: no second backfill
  fillBench(*store, 2, 20, "SN-A2");
  const LabEndpoint ep = cluster_.addBench("bench_a");
  Shipper shipper(ep, *store);
  for (int i = 0; i < 100 && backlog(*store) > 0; ++i) {
    const ShipStep s = shipper.step();
    ASSERT_TRUE(s.error.ok()) << s.error.message;
  }
  EXPECT_EQ(backlog(*store), 0);
  expectMirrored(cluster_, "bench_a", store->path());
  // The queue's history from the outbox's start: the plan queued after it, with when it left
  // (the one queued and gone before the outbox existed is not in SQLite any more).
  const Items queue = labItems(cluster_, "bench_a", "= 'queue'");
  ASSERT_EQ(queue.size(), 1U);
  for (const auto& [k, v] : queue) EXPECT_TRUE(v["left_unix_s"].is_number()) << v.dump();
  // A discarded segment is deleted in the lab too (segment 2 of each run).
  EXPECT_EQ(cluster_.admin("SELECT count(*) FROM lab.items WHERE item = 'segment/2'"), "0");
  // The readers: runs and results of the serial, as the CLI reads them.
  const auto runs = readLabRuns(cluster_.reader());
  ASSERT_TRUE(runs.ok()) << runs.status.message;
  EXPECT_EQ(runs.value.size(), 5U);
  const auto res = readLabResults(cluster_.reader(), {std::string("SN-A2"), {}, {}});
  ASSERT_TRUE(res.ok()) << res.status.message;
  EXPECT_EQ(res.value.size(), 2U);
}

// The must-show outage: the database stops mid-shipping for IMUBENCH_LAB_OUTAGE_S (60 s) while
// the bench keeps writing; the mirror reports the fault and the backlog, the bench never waits
// on it, and after the restart every item is there once.
TEST_F(LabMirrorTest, DatabaseStoppedMidShippingThenStartedDeliversEverythingOnce) {
  const char* env = std::getenv("IMUBENCH_LAB_OUTAGE_S");
  const double outage_s = env != nullptr ? std::atof(env) : 60.0;
  auto store = openStore("b");
  const LabEndpoint ep = cluster_.addBench("bench_b");
  ShipperOptions opt = fastRetry();
  opt.batch_items = 20;  // many transactions, so the stop lands between and inside them
  fillBench(*store, 10, 100, "SN-B");
  auto mirror = LabMirror::start(store->path(), ep, opt);
  ASSERT_TRUE(mirror.ok()) << mirror.status.message;
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().shipped > 0; }, 30));
  ASSERT_GT(backlog(*store), 0) << "shipping finished before the stop: test proves nothing";
  ASSERT_EQ(cluster_.stop(), 0);
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().state == "fault"; }, 30));
  const MirrorStatus down = mirror.value->status();
  EXPECT_EQ(down.fault, LabFault::kUnreachable) << down.message;
  EXPECT_GT(down.backlog, 0);
  // The bench keeps running: writes go on, each fast, while the lab is down.
  double worst_write_s = 0.0;
  const double until = now() + outage_s;
  int written = 0;
  while (now() < until) {
    const double t0 = now();
    ASSERT_TRUE(store
                    ->addEvent({1, t0, daemon::EventSeverity::kInfo, "while_down",
                                "{\"n\":" + std::to_string(written++) + "}"})
                    .ok);
    worst_write_s = std::max(worst_write_s, now() - t0);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_LT(worst_write_s, 0.25) << "a bench write waited on the lab mirror";
  EXPECT_EQ(mirror.value->status().state, "fault");
  EXPECT_GE(mirror.value->status().backlog, down.backlog + written - 50);
  ASSERT_EQ(cluster_.start(), 0);
  ASSERT_TRUE(waitFor(
      [&] {
        const MirrorStatus s = mirror.value->status();
        return s.state == "ok" && s.backlog == 0;
      },
      60))
      << mirror.value->status().message;
  mirror.value->stop();
  expectMirrored(cluster_, "bench_b", store->path());
}

// kill -9 of a shipping process: what it committed in the lab but had not acknowledged is
// shipped again by the next one, without effect.
TEST_F(LabMirrorTest, ShipperKilledWhileShippingLosesAndDuplicatesNothing) {
  auto store = openStore("k");
  const LabEndpoint ep = cluster_.addBench("bench_k");
  fillBench(*store, 10, 200, "SN-K");
  ASSERT_TRUE(store->enableOutbox().ok);
  const int total = backlog(*store);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto own = Store::open(store->path());
    if (!own.ok()) _exit(3);
    ShipperOptions opt;
    opt.batch_items = 20;
    Shipper shipper(ep, *own.value, opt);
    for (;;) {
      const ShipStep s = shipper.step();
      if (!s.error.ok()) _exit(4);
      if (s.backlog == 0) _exit(0);
    }
  }
  const std::string count = "SELECT count(*) FROM lab.items WHERE bench_id = 'bench_k'";
  waitFor([&] { return std::atoi(cluster_.admin(count).c_str()) >= total / 4; }, 60);
  ::kill(child, SIGKILL);
  int wstatus = 0;
  ASSERT_EQ(::waitpid(child, &wstatus, 0), child);
  ASSERT_TRUE(WIFSIGNALED(wstatus)) << "the shipper ended (exit " << WEXITSTATUS(wstatus)
                                    << ") before the kill: the test proves nothing";
  const int arrived = std::atoi(cluster_.admin(count).c_str());
  EXPECT_GT(arrived, 0);
  EXPECT_LT(arrived, total);
  Shipper again(ep, *store);
  for (int i = 0; i < 1000 && backlog(*store) > 0; ++i) ASSERT_TRUE(again.step().error.ok());
  expectMirrored(cluster_, "bench_k", store->path());
}

// Wrong password: a clear fault (naming authentication, never the password); the bench writes
// on; delivery resumes once the password file is right.
TEST_F(LabMirrorTest, WrongPasswordIsReportedAndDeliveryResumesOnceFixed) {
  auto store = openStore("p");
  LabEndpoint ep = cluster_.addBench("bench_p");
  const std::string right = [&] {
    std::ifstream in(ep.password_file);
    std::string s;
    std::getline(in, s);
    return s;
  }();
  const std::string wrong = "not-" + right;
  ep.password_file = cluster_.root() + "/p.pass";
  auto write = [&](const std::string& pw) {
    std::ofstream(ep.password_file) << pw << "\n";
    std::filesystem::permissions(ep.password_file, std::filesystem::perms(0600));
  };
  write(wrong);
  fillBench(*store, 2, 10, "SN-P");
  auto mirror = LabMirror::start(store->path(), ep, fastRetry());
  ASSERT_TRUE(mirror.ok()) << mirror.status.message;
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().state == "fault"; }, 30));
  const MirrorStatus st = mirror.value->status();
  EXPECT_EQ(st.fault, LabFault::kAuth) << st.message;
  EXPECT_NE(st.message.find("password authentication failed"), std::string::npos) << st.message;
  EXPECT_EQ(st.message.find(wrong), std::string::npos) << "the password leaked into the status";
  EXPECT_GT(st.backlog, 0);
  fillBench(*store, 1, 10, "SN-P");  // the bench keeps running
  write(right);
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().backlog == 0; }, 30))
      << mirror.value->status().message;
  EXPECT_EQ(mirror.value->status().state, "ok");
  mirror.value->stop();
  expectMirrored(cluster_, "bench_p", store->path());
}

// The writer configured with the read-only role: a rights fault; granted writing, it resumes.
TEST_F(LabMirrorTest, ReadOnlyRoleIsReportedAndDeliveryResumesOnceGranted) {
  auto store = openStore("r");
  fillBench(*store, 2, 10, "SN-R");
  auto mirror = LabMirror::start(store->path(), cluster_.reader(), fastRetry());
  ASSERT_TRUE(mirror.ok()) << mirror.status.message;
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().state == "fault"; }, 30));
  const MirrorStatus st = mirror.value->status();
  EXPECT_EQ(st.fault, LabFault::kRights) << st.message;
  EXPECT_NE(st.message.find("permission denied"), std::string::npos) << st.message;
  EXPECT_GT(st.backlog, 0);
  cluster_.admin("GRANT lab_writer TO lab_read");
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().backlog == 0; }, 30))
      << mirror.value->status().message;
  mirror.value->stop();
  expectMirrored(cluster_, "lab_read", store->path());
}

// SQL in plan labels, serials, run (plan) names and event details is data: stored verbatim.
TEST_F(LabMirrorTest, InjectionAttemptsAreStoredVerbatim) {
  auto store = openStore("h");
  ASSERT_TRUE(store->enableOutbox().ok);
  for (const char* text : kHostile) fillBench(*store, 1, 2, text, text);
  const LabEndpoint ep = cluster_.addBench("bench_h");
  Shipper shipper(ep, *store);
  for (int i = 0; i < 20 && backlog(*store) > 0; ++i) {
    const ShipStep s = shipper.step();
    ASSERT_TRUE(s.error.ok()) << s.error.message;
  }
  expectMirrored(cluster_, "bench_h", store->path());
  EXPECT_EQ(cluster_.admin("SELECT count(*) FROM pg_roles WHERE rolname = 'lab_writer'"), "1");
  for (const char* text : kHostile) {
    const auto res = readLabResults(cluster_.reader(), {std::string(text), {}, {}});
    ASSERT_TRUE(res.ok()) << res.status.message;
    ASSERT_EQ(res.value.size(), 1U) << text;
    EXPECT_EQ(res.value[0].imu_serial, text);
    EXPECT_EQ(nlohmann::json::parse(res.value[0].json)["label"], text);
  }
  const auto runs = readLabRuns(cluster_.reader());
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs.value.size(), std::size(kHostile));
  for (std::size_t i = 0; i < runs.value.size(); ++i) {
    EXPECT_EQ(runs.value[i].plan_name, std::string(kHostile[i]) + " plan");
  }
}

// A lab schema newer than this imubench (or none): a schema fault, nothing written.
TEST_F(LabMirrorTest, SchemaNewerOrMissingIsAFaultNotAMisWrite) {
  auto store = openStore("s");
  ASSERT_TRUE(store->enableOutbox().ok);
  fillBench(*store, 1, 2, "SN-S");
  const LabEndpoint ep = cluster_.addBench("bench_s");
  cluster_.admin("INSERT INTO lab.schema_version(version) VALUES (99)");
  Shipper shipper(ep, *store);
  ShipStep s = shipper.step();
  EXPECT_EQ(s.error.fault, LabFault::kSchema);
  EXPECT_NE(s.error.message.find("newer"), std::string::npos) << s.error.message;
  EXPECT_EQ(s.shipped, 0);
  cluster_.admin("DELETE FROM lab.schema_version WHERE version = 99");
  s = shipper.step();
  EXPECT_TRUE(s.error.ok()) << s.error.message;
  EXPECT_GT(s.shipped, 0);
}

// ---------------------------------------------------------------------------------------
// Raw samples ([lab] mirror_samples): every row of every stream once, bit-exact.

// The streams as the test knows them (written here, not taken from the code under test).
struct StreamCols {
  const char* sqlite_table;
  const char* lab_table;
  const char* columns;
};
constexpr StreamCols kStreams[] = {
    {"imu_samples", "lab.imu_samples", "t, dthx, dthy, dthz, dvx, dvy, dvz, temp_c"},
    {"table_samples", "lab.table_samples", "t, angle0_deg, angle1_deg, angle2_deg, round_trip_s"},
    {"chamber_samples", "lab.chamber_samples", "t, setpoint_c, temp_c"},
};

// Awkward but finite values: signed zeros, subnormals, extremes, and ordinary noise.
double awkward(std::mt19937_64& rng) {
  static constexpr double kSpecial[] = {-0.0,
                                        0.0,
                                        4.9406564584124654e-324,
                                        -2.2250738585072014e-308,
                                        1.7976931348623157e308,
                                        -1e-300,
                                        0.1,
                                        1.0 / 3.0};
  const std::uint64_t k = rng();
  if (k % 16 == 0) return kSpecial[(k >> 8) % std::size(kSpecial)];
  return std::normal_distribution<double>(0.0, 1e-3)(rng);
}

// Samples of a 2 kHz IMU, a 100 Hz table and a 1 Hz chamber from t0 for n IMU rows.
daemon::RunBatch sampleBatch(std::mt19937_64& rng, std::int64_t first_imu, int n) {
  daemon::RunBatch b;
  for (std::int64_t i = first_imu; i < first_imu + n; ++i) {
    nav::ImuSample s;
    s.t = 0.0005 * static_cast<double>(i + 1);
    for (int a = 0; a < 3; ++a) {
      s.dtheta[a] = awkward(rng);
      s.dvel[a] = awkward(rng);
    }
    s.temp_c = i % 7 == 0 ? std::numeric_limits<double>::quiet_NaN() : 25.0 + awkward(rng);
    b.imu.push_back(s);
    if (i % 20 == 0) {
      b.table.push_back({s.t, {awkward(rng), 90.0 + awkward(rng), -0.0}});
      b.table_round_trip_s.push_back(i % 40 == 0 ? std::numeric_limits<double>::quiet_NaN()
                                                 : 0.002 + std::abs(awkward(rng)));
    }
    if (i % 2000 == 0) b.chamber.push_back({s.t, 40.0, 40.0 + awkward(rng)});
  }
  return b;
}

std::int64_t beginSampleRun(Store& store, const std::string& serial) {
  daemon::RunStart start;
  start.plan_name = "samples";
  start.plan_toml = "[plan]";
  start.bench_name = "samples";
  start.imu_serial = serial;
  start.imu_rate_hz = 2000.0;
  const auto id = store.beginRun(start);
  EXPECT_TRUE(id.ok()) << id.status.message;
  return id.value;
}

void mixDouble(std::uint64_t& h, double v, bool null) {
  std::uint64_t bits = 0x4e554c4cULL;  // "NULL"
  if (!null) std::memcpy(&bits, &v, 8);
  for (int k = 0; k < 8; ++k) h = (h ^ ((bits >> (8 * k)) & 0xff)) * 1099511628211ULL;
}

struct StreamSum {
  std::int64_t rows = 0;
  std::uint64_t hash = 1469598103934665603ULL;
  bool operator==(const StreamSum&) const = default;
};

// FNV-1a over (run, every value's bits or NULL) of the bench's SQLite rows in (run, t) order.
StreamSum sqliteSum(const std::string& path, const StreamCols& s) {
  StreamSum sum;
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  const std::string sql = std::string("SELECT run_id, ") + s.columns + " FROM " + s.sqlite_table +
                          " ORDER BY run_id, t";
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &q, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  while (sqlite3_step(q) == SQLITE_ROW) {
    ++sum.rows;
    mixDouble(sum.hash, static_cast<double>(sqlite3_column_int64(q, 0)), false);
    for (int c = 1; c < sqlite3_column_count(q); ++c) {
      mixDouble(sum.hash, sqlite3_column_double(q, c), sqlite3_column_type(q, c) == SQLITE_NULL);
    }
  }
  sqlite3_finalize(q);
  sqlite3_close(db);
  return sum;
}

// The same over the lab's rows of one bench (binary results: the doubles as stored).
StreamSum labSum(const LabCluster& cluster, const std::string& bench, const StreamCols& s) {
  StreamSum sum;
  PgConn c(PQconnectdb(cluster.adminConninfo().c_str()));
  const std::string sql = std::string("SELECT run_id::float8, ") + s.columns + " FROM " +
                          s.lab_table + " WHERE bench_id = $1 ORDER BY run_id, t";
  const char* params[] = {bench.c_str()};
  PgResult r(PQexecParams(c.get(), sql.c_str(), 1, nullptr, params, nullptr, nullptr, 1));
  EXPECT_EQ(PQresultStatus(r.get()), PGRES_TUPLES_OK) << PQresultErrorMessage(r.get());
  for (int i = 0; i < PQntuples(r.get()); ++i) {
    ++sum.rows;
    for (int col = 0; col < PQnfields(r.get()); ++col) {
      std::uint64_t bits = 0;
      const bool null = PQgetisnull(r.get(), i, col) != 0;
      if (!null) std::memcpy(&bits, PQgetvalue(r.get(), i, col), 8);
      bits = be64toh(bits);
      double v = 0.0;
      std::memcpy(&v, &bits, 8);
      mixDouble(sum.hash, v, null);
    }
  }
  return sum;
}

void expectSamplesMirrored(const LabCluster& cluster, const std::string& bench,
                           const std::string& store_path) {
  for (const StreamCols& s : kStreams) {
    const StreamSum want = sqliteSum(store_path, s);
    const StreamSum got = labSum(cluster, bench, s);
    EXPECT_GT(want.rows, 0) << s.sqlite_table;
    EXPECT_EQ(got.rows, want.rows) << s.lab_table << " rows";
    EXPECT_EQ(got.hash, want.hash) << s.lab_table << " checksum";
  }
}

std::int64_t labRows(const LabCluster& cluster, const std::string& bench) {
  return std::atoll(
      cluster
          .admin("SELECT (SELECT count(*) FROM lab.imu_samples WHERE bench_id = '" + bench +
                 "') + (SELECT count(*) FROM lab.table_samples WHERE bench_id = '" + bench +
                 "') + (SELECT count(*) FROM lab.chamber_samples WHERE bench_id = '" + bench + "')")
          .c_str());
}

ShipperOptions withSamples(ShipperOptions o, std::size_t batch_rows) {
  o.mirror_samples = true;
  o.samples.batch_rows = batch_rows;
  o.samples.backlog_every_s = 0.0;  // the tests read the backlog after every step
  return o;
}

// Ships until both backlogs are empty; every step must succeed.
void drain(Shipper& shipper, int max_steps) {
  for (int i = 0; i < max_steps; ++i) {
    const ShipStep s = shipper.step();
    ASSERT_TRUE(s.error.ok()) << s.error.message;
    if (s.backlog == 0 && s.samples_backlog == 0) return;
  }
  FAIL() << "the backlog did not drain in " << max_steps << " steps";
}

TEST_F(LabMirrorTest, SamplesAreMirroredExactlyOnceWithEqualCountsAndChecksums) {
  auto store = openStore("m");
  std::mt19937_64 rng(30);
  const std::int64_t done = beginSampleRun(*store, "SN-M1");
  ASSERT_TRUE(store->appendBatch(done, sampleBatch(rng, 0, 7001)).ok);
  ASSERT_TRUE(store->finishRun(done, daemon::RunState::kFinished, "").ok);
  const std::int64_t running = beginSampleRun(*store, "SN-M2");
  ASSERT_TRUE(store->appendBatch(running, sampleBatch(rng, 0, 3000)).ok);
  ASSERT_TRUE(store->enableOutbox().ok);
  const LabEndpoint ep = cluster_.addBench("bench_m");
  Shipper shipper(ep, *store, withSamples({}, 2500));
  drain(shipper, 100);
  expectSamplesMirrored(cluster_, "bench_m", store->path());
  // The running run goes on: only the new rows follow, once.
  ASSERT_TRUE(store->appendBatch(running, sampleBatch(rng, 3000, 4321)).ok);
  drain(shipper, 100);
  expectSamplesMirrored(cluster_, "bench_m", store->path());
  // What the design rests on: a stream only grows after its newest stored row.
  const Status late = store->appendBatch(running, sampleBatch(rng, 10, 5));
  EXPECT_FALSE(late.ok);
  EXPECT_NE(late.message.find("time does not increase past the stored"), std::string::npos)
      << late.message;
  // A mark lost in the lab (deleted by hand): the rows are shipped again, never duplicated.
  cluster_.admin("DELETE FROM lab.sample_marks WHERE bench_id = 'bench_m'");
  Shipper again(ep, *store, withSamples({}, 2500));
  drain(again, 100);
  expectSamplesMirrored(cluster_, "bench_m", store->path());
  // The readers' views, as the read-only role sees them.
  PgConn reader;
  ASSERT_TRUE(connectLab(cluster_.reader(), "test", &reader).ok());
  PgResult r(PQexec(reader.get(), "SELECT count(*) FROM lab.imu WHERE imu_serial = 'SN-M2'"));
  ASSERT_EQ(PQresultStatus(r.get()), PGRES_TUPLES_OK) << PQresultErrorMessage(r.get());
  EXPECT_STREQ(PQgetvalue(r.get(), 0, 0), "7321");
}

// The database stops while samples ship, the bench writes on at 2 kHz (never waiting), the
// status counts the waiting rows; after the restart every row is there once.
TEST_F(LabMirrorTest, SamplesThroughADatabaseStoppedMidShippingArriveOnce) {
  const char* env = std::getenv("IMUBENCH_LAB_OUTAGE_S");
  const double outage_s = env != nullptr ? std::atof(env) : 20.0;
  auto store = openStore("o");
  std::mt19937_64 rng(31);
  const std::int64_t run = beginSampleRun(*store, "SN-O");
  std::int64_t next = 0;
  for (; next < 120000; next += 4000) {
    ASSERT_TRUE(store->appendBatch(run, sampleBatch(rng, next, 4000)).ok);
  }
  const LabEndpoint ep = cluster_.addBench("bench_o");
  auto mirror = LabMirror::start(store->path(), ep, withSamples(fastRetry(), 2000));
  ASSERT_TRUE(mirror.ok()) << mirror.status.message;
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().samples_shipped > 0; }, 30));
  ASSERT_GT(mirror.value->status().samples_backlog, 0) << "shipped before the stop: proves nothing";
  ASSERT_EQ(cluster_.stop(), 0);
  ASSERT_TRUE(waitFor([&] { return mirror.value->status().state == "fault"; }, 30));
  EXPECT_EQ(mirror.value->status().fault, LabFault::kUnreachable);
  double worst_write_s = 0.0;
  const double until = now() + outage_s;
  while (now() < until) {  // 2 kHz in batches of 100 every 50 ms
    const double t0 = now();
    ASSERT_TRUE(store->appendBatch(run, sampleBatch(rng, next, 100)).ok);
    next += 100;
    worst_write_s = std::max(worst_write_s, now() - t0);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_LT(worst_write_s, 0.25) << "a bench write waited on the lab mirror";
  const MirrorStatus down = mirror.value->status();
  EXPECT_EQ(down.state, "fault");
  EXPECT_GT(down.samples_backlog, static_cast<std::int64_t>(outage_s * 1000)) << down.message;
  ASSERT_EQ(cluster_.start(), 0);
  ASSERT_TRUE(waitFor(
      [&] {
        const MirrorStatus s = mirror.value->status();
        return s.state == "ok" && s.samples_backlog == 0;
      },
      120))
      << mirror.value->status().message;
  mirror.value->stop();
  expectSamplesMirrored(cluster_, "bench_o", store->path());
}

// kill -9 of a process shipping samples, mid-batch: the next shipper resumes after what the
// lab committed (its marks), so nothing is lost and nothing arrives twice.
TEST_F(LabMirrorTest, SampleShipperKilledMidBatchThenRestartedLosesAndDuplicatesNothing) {
  auto store = openStore("x");
  std::mt19937_64 rng(32);
  for (int r = 0; r < 2; ++r) {
    const std::int64_t run = beginSampleRun(*store, "SN-X");
    for (std::int64_t i = 0; i < 100000; i += 5000) {
      ASSERT_TRUE(store->appendBatch(run, sampleBatch(rng, i, 5000)).ok);
    }
  }
  const std::int64_t total = sqliteSum(store->path(), kStreams[0]).rows +
                             sqliteSum(store->path(), kStreams[1]).rows +
                             sqliteSum(store->path(), kStreams[2]).rows;
  const LabEndpoint ep = cluster_.addBench("bench_x");
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto own = Store::open(store->path());
    if (!own.ok()) _exit(3);
    Shipper shipper(ep, *own.value, withSamples({}, 3000));
    for (;;) {
      const ShipStep s = shipper.step();
      if (!s.error.ok()) _exit(4);
      if (s.samples_backlog == 0) _exit(0);
    }
  }
  waitFor([&] { return labRows(cluster_, "bench_x") >= total / 3; }, 120);
  ::kill(child, SIGKILL);
  int wstatus = 0;
  ASSERT_EQ(::waitpid(child, &wstatus, 0), child);
  ASSERT_TRUE(WIFSIGNALED(wstatus)) << "the shipper ended (exit " << WEXITSTATUS(wstatus)
                                    << ") before the kill: the test proves nothing";
  const std::int64_t arrived = labRows(cluster_, "bench_x");
  EXPECT_GT(arrived, 0);
  EXPECT_LT(arrived, total);
  Shipper again(ep, *store, withSamples({}, 3000));
  drain(again, 1000);
  expectSamplesMirrored(cluster_, "bench_x", store->path());
  // The marks account for every row exactly once: no batch was applied twice.
  EXPECT_EQ(std::atoll(cluster_
                           .admin("SELECT sum(shipped_rows) FROM lab.sample_marks "
                                  "WHERE bench_id = 'bench_x'")
                           .c_str()),
            total);
}

TEST(LabConfig, PasswordInTheUriOrAnOpenPasswordFileIsRefused) {
  const Status st = checkConninfo("postgresql://bench:secret@127.0.0.1/lab");
  EXPECT_FALSE(st.ok);
  EXPECT_EQ(st.message.find("secret"), std::string::npos);
  EXPECT_TRUE(checkConninfo("postgresql://bench@127.0.0.1:5433/lab").ok);
  char path[] = "/tmp/imubench-labpw-XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::write(fd, "pw\n", 3), 3);
  ::close(fd);
  ::chmod(path, 0644);
  const auto open = readPasswordFile(path);
  EXPECT_FALSE(open.ok());
  EXPECT_NE(open.status.message.find("chmod 600"), std::string::npos);
  ::chmod(path, 0600);
  const auto closed = readPasswordFile(path);
  EXPECT_TRUE(closed.ok());
  EXPECT_EQ(closed.value, "pw");
  ::unlink(path);
}

}  // namespace
}  // namespace imubench::lab
