// The SQLite run store: bit-exact io::Recording round trip, run life cycle, results, refusal of
// bad input (corrupt file, newer schema, unknown run, non-finite samples), and crash safety:
// a writer killed with SIGKILL loses at most the unflushed tail of its samples.
#include "daemon/store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <thread>

#include "tests/daemon/recording_fixtures.h"

namespace imubench::daemon {
namespace {

using testing::AwkwardDoubles;
using testing::ScratchDir;

namespace fs = std::filesystem;

// Awkward doubles on purpose: random mantissas over many exponents, negative zero,
// subnormals, extremes, NaN temperatures (not reported).
io::Recording makeRecording(unsigned seed, calib::TableKind kind, size_t n_imu) {
  AwkwardDoubles d(seed);
  io::Recording rec =
      testing::awkwardRecording(d, kind, n_imu, -0.0, "SN-0042 \"test\", with comma");
  rec.imu[5].dvel.x() = 3.0;  // integral: SQLite REAL affinity would store it as an integer
  for (int i = 0; i < 300; ++i) {
    io::TableSample s;
    s.t = 0.01 * i + d.odd() * 1e-6;
    for (int a = 0; a < 3; ++a) s.angles_deg[static_cast<size_t>(a)] = 180.0 * d.unit();
    rec.table.push_back(s);
  }
  rec.table[7].angles_deg[1] = -0.0;
  for (int i = 0; i < 40; ++i) rec.chamber.push_back({0.1 * i + 1e-9, 25.0 + i, 24.5 + d.odd()});
  const double third = 1.0 / 3.0;
  rec.segments.push_back({0.5, 0.5 + third, calib::SegmentKind::kStatic, "static-1", true});
  rec.segments.push_back(
      {1.0, 1.7, calib::SegmentKind::kRotate, "rotate \"x\", +180", true, 1, -kPi});
  rec.segments.push_back({1.7, 2.0, calib::SegmentKind::kSoak, "", false});
  rec.segments.push_back({2.0, 2.5, calib::SegmentKind::kMove, "move-1", true, -1, -0.0});
  rec.segments_from_file = true;
  return rec;
}

// Every field bit for bit: the store keeps segments_from_file and the segments' recording
// flag, axis and angle too.
void expectSameStored(const io::Recording& a, const io::Recording& b) {
  EXPECT_EQ(a.segments_from_file, b.segments_from_file);
  testing::expectSameRecording(a, b);
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (size_t i = 0; i < a.segments.size(); ++i) {
    const auto &x = a.segments[i], &y = b.segments[i];
    EXPECT_TRUE(testing::sameBits(x.angle, y.angle)) << "segment " << i;
    EXPECT_EQ(x.recording, y.recording);
    EXPECT_EQ(x.axis, y.axis);
  }
}

std::unique_ptr<Store> openOrFail(const std::string& path, const StoreOptions& options = {}) {
  auto r = Store::open(path, options);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return std::move(r.value);
}

// IMU samples 1..n periods after 0 (nothing else set).
nav::ImuSamples samplesEvery(std::size_t n, double period) {
  nav::ImuSamples imu(n);
  for (std::size_t i = 0; i < n; ++i) imu[i].t = period * static_cast<double>(i + 1);
  return imu;
}

RunStart benchStart(const std::string& serial) {
  RunStart s;
  s.plan_name = "direct-12";
  s.plan_toml = "[plan]\nname = \"direct-12\"\n";
  s.bench_name = "bench-a";
  s.imu_serial = serial;
  s.imu_rate_hz = 2000.0;
  s.latitude_deg = 55.75;
  s.height_m = 150.0;
  return s;
}

// A store in `dir` with one run begun for `serial` (its id in *run); nullptr after a failure.
std::unique_ptr<Store> storeWithRun(const ScratchDir& dir, const std::string& serial,
                                    std::int64_t* run) {
  auto store = openOrFail(dir.file("bench.db"));
  if (!store) return nullptr;
  const RunIdResult begun = store->beginRun(benchStart(serial));
  EXPECT_TRUE(begun.status.ok) << begun.status.message;
  if (!begun.status.ok) return nullptr;
  *run = begun.value;
  return store;
}

TEST(Store, ImportedRecordingLoadsBitExactAndExports) {
  ScratchDir dir("store");
  auto store = openOrFail(dir.file("bench.db"));
  ASSERT_TRUE(store);
  for (auto kind : {calib::TableKind::kTwoAxis, calib::TableKind::kThreeAxis}) {
    const io::Recording rec = makeRecording(7, kind, 6000);
    RunStart start = runStartFromRecording(rec);
    start.plan_name = "imported";
    const RunIdResult run = store->importRecording(start, rec);
    ASSERT_TRUE(run.status.ok) << run.status.message;
    const io::RecordingReadResult loaded = store->loadRecording(run.value);
    ASSERT_TRUE(loaded.status.ok) << loaded.status.message;
    expectSameStored(rec, loaded.value);
    const RunInfoResult info = store->runInfo(run.value);
    ASSERT_TRUE(info.status.ok);
    EXPECT_EQ(info.value.state, RunState::kFinished);
    EXPECT_EQ(info.value.start.plan_name, "imported");
    // The loaded value exports as imubench-csv/1.
    const Status st = io::writeRecording(dir.file("export"), loaded.value);
    EXPECT_TRUE(st.ok) << st.message;
  }
}

TEST(Store, LiveRunThroughRunWriterLoadsBitExact) {
  ScratchDir dir("store");
  auto store = openOrFail(dir.file("bench.db"));
  ASSERT_TRUE(store);
  const io::Recording rec = makeRecording(11, calib::TableKind::kTwoAxis, 5000);
  const RunIdResult run = store->beginRun(runStartFromRecording(rec));
  ASSERT_TRUE(run.status.ok) << run.status.message;
  {
    RunWriter writer(*store, run.value);
    const std::span<const nav::ImuSample> imu(rec.imu);
    for (size_t i = 0; i < imu.size(); i += 37) {
      const Status st = writer.appendImu(imu.subspan(i, std::min<size_t>(37, imu.size() - i)));
      ASSERT_TRUE(st.ok) << st.message;
      // Time-based flushing keeps the buffer at about max_unflushed_s of samples.
      EXPECT_LE(writer.bufferedRows(), 1100u);
    }
    ASSERT_TRUE(writer.appendTable(rec.table).ok);
    ASSERT_TRUE(writer.appendChamber(rec.chamber).ok);
    for (const auto& s : rec.segments) ASSERT_TRUE(writer.appendSegment(s).ok);
    const Status st = writer.flush();
    ASSERT_TRUE(st.ok) << st.message;
    EXPECT_EQ(writer.bufferedRows(), 0u);
  }
  ASSERT_TRUE(store->finishRun(run.value, RunState::kFinished, "plan complete").ok);
  const io::RecordingReadResult loaded = store->loadRecording(run.value);
  ASSERT_TRUE(loaded.status.ok) << loaded.status.message;
  expectSameStored(rec, loaded.value);
}

// Each table reading's read round trip is stored beside it (known or not, across flushes), read
// back in time order, and never part of the recording; a count that does not match the rows or
// a negative round trip is refused with nothing buffered.
TEST(Store, TableRoundTripsAreStoredBesideTheReadings) {
  ScratchDir dir("store");
  StoreOptions small;
  small.max_unflushed_rows = 7;  // flushes in the middle of the appends below
  auto opened = Store::open(dir.file("bench.db"), small);
  ASSERT_TRUE(opened.status.ok) << opened.status.message;
  Store& store = *opened.value;
  const io::Recording rec = makeRecording(3, calib::TableKind::kTwoAxis, 400);
  ASSERT_GE(rec.table.size(), 20u);
  const RunIdResult run = store.beginRun(runStartFromRecording(rec));
  ASSERT_TRUE(run.status.ok) << run.status.message;
  std::vector<std::optional<double>> expected;
  {
    RunWriter writer(store, run.value);
    const double bad[2] = {0.01, 0.02};
    EXPECT_FALSE(writer.appendTable(std::span(rec.table).first(1), std::span(bad, 2)).ok);
    const double negative = -0.001;
    EXPECT_FALSE(writer.appendTable(std::span(rec.table).first(1), std::span(&negative, 1)).ok);
    for (std::size_t i = 0; i < 20; ++i) {
      const auto row = std::span(rec.table).subspan(i, 1);
      if (i % 3 == 0) {  // unknown: no round trip given
        ASSERT_TRUE(writer.appendTable(row).ok);
        expected.emplace_back();
      } else {
        const double rt = 0.015 + 0.001 * static_cast<double>(i);
        ASSERT_TRUE(writer.appendTable(row, std::span(&rt, 1)).ok);
        expected.emplace_back(rt);
      }
    }
    ASSERT_TRUE(writer.flush().ok);
  }
  const TableRoundTripsResult trips = store.tableRoundTrips(run.value);
  ASSERT_TRUE(trips.status.ok) << trips.status.message;
  ASSERT_EQ(trips.value.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(trips.value[i].t, rec.table[i].t);
    EXPECT_EQ(trips.value[i].round_trip_s, expected[i]) << "row " << i;
  }
  const io::RecordingReadResult loaded = store.loadRecording(run.value);
  ASSERT_TRUE(loaded.status.ok);
  ASSERT_EQ(loaded.value.table.size(), expected.size());
  EXPECT_FALSE(store.tableRoundTrips(run.value + 1).status.ok);
}

TEST(Store, DatabaseIsWalWithSchemaVersion) {
  ScratchDir dir("store");
  const std::string path = dir.file("bench.db");
  ASSERT_TRUE(openOrFail(path));
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &q, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(q), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(q, 0)), "wal");
  sqlite3_finalize(q);
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &q, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(q), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(q, 0), kStoreSchemaVersion);
  sqlite3_finalize(q);
  sqlite3_close(db);
}

TEST(Store, RunLifeCycleEventsAndResults) {
  ScratchDir dir("store");
  auto store = openOrFail(dir.file("bench.db"));
  ASSERT_TRUE(store);
  const auto a = store->beginRun(benchStart("SN-A"));
  const auto b = store->beginRun(benchStart("SN-B"));
  const auto c = store->beginRun(benchStart("SN-A"));
  ASSERT_TRUE(a.status.ok && b.status.ok && c.status.ok);
  ASSERT_TRUE(store->finishRun(a.value, RunState::kFinished, "done").ok);
  ASSERT_TRUE(store->finishRun(b.value, RunState::kFaulted, "table overtemperature").ok);
  const Status again = store->finishRun(a.value, RunState::kAborted, "x");
  EXPECT_FALSE(again.ok);
  EXPECT_NE(again.message.find("is finished, not running"), std::string::npos) << again.message;
  EXPECT_FALSE(store->finishRun(c.value, RunState::kRunning, "x").ok);

  const CountResult marked = store->markInterruptedRuns();
  ASSERT_TRUE(marked.status.ok) << marked.status.message;
  EXPECT_EQ(marked.value, 1);
  const RunListResult runs = store->listRuns();
  ASSERT_TRUE(runs.status.ok);
  ASSERT_EQ(runs.value.size(), 3u);
  EXPECT_EQ(runs.value[0].state, RunState::kFinished);
  EXPECT_EQ(runs.value[1].state, RunState::kFaulted);
  EXPECT_EQ(runs.value[1].exit_reason, "table overtemperature");
  EXPECT_TRUE(runs.value[1].finished_unix_s.has_value());
  EXPECT_EQ(runs.value[2].state, RunState::kInterrupted);
  EXPECT_EQ(runs.value[2].start.plan_toml, benchStart("").plan_toml);
  const EventListResult events = store->events(c.value);
  ASSERT_TRUE(events.status.ok);
  ASSERT_EQ(events.value.size(), 1u);
  EXPECT_EQ(events.value[0].kind, "interrupted");
  EXPECT_EQ(events.value[0].severity, EventSeverity::kWarning);
  EXPECT_EQ(store->markInterruptedRuns().value, 0);
  const EventListResult faulted = store->events(b.value);
  ASSERT_TRUE(faulted.status.ok);
  ASSERT_EQ(faulted.value.size(), 1u);
  EXPECT_EQ(faulted.value[0].kind, "run-end");
  EXPECT_EQ(faulted.value[0].severity, EventSeverity::kError);
  EXPECT_NE(faulted.value[0].json.find("table overtemperature"), std::string::npos);

  EXPECT_TRUE(store->addEvent({a.value, 1.0, EventSeverity::kInfo, "note", "{\"x\": 1}"}).ok);
  EXPECT_FALSE(store->addEvent({a.value, 1.0, EventSeverity::kInfo, "note", "{x"}).ok);

  ASSERT_TRUE(store->storeResult(a.value, "SN-A", 25.0, "coefficients", "{\"b\": 1}").status.ok);
  ASSERT_TRUE(store->storeResult(b.value, "SN-B", 25.0, "coefficients", "{}").status.ok);
  ASSERT_TRUE(store->storeResult(c.value, "SN-A", -10.0, "report", "[1, 2]").status.ok);
  EXPECT_FALSE(store->storeResult(a.value, "SN-A", 25.0, "report", "not json").status.ok);
  EXPECT_FALSE(store->storeResult(99, "SN-A", 25.0, "report", "{}").status.ok);
  const ResultListResult by_serial = store->results({std::string("SN-A"), std::nullopt});
  ASSERT_TRUE(by_serial.status.ok);
  ASSERT_EQ(by_serial.value.size(), 2u);
  EXPECT_EQ(by_serial.value[1].kind, "report");
  EXPECT_EQ(by_serial.value[1].json, "[1, 2]");
  EXPECT_EQ(by_serial.value[1].temperature_c, -10.0);
  EXPECT_EQ(store->results({std::nullopt, b.value}).value.size(), 1u);
  EXPECT_EQ(store->results().value.size(), 3u);
}

// Crash resume: an interrupted run names its last stored sample, resumes from the last
// step_finished event, and its writer continues after the stored rows (never before them).
TEST(Store, InterruptedRunResumesAfterItsLastFinishedStep) {
  ScratchDir dir("store");
  std::int64_t run = 0;
  auto store = storeWithRun(dir, "SN-R", &run);
  ASSERT_TRUE(store);
  {
    RunWriter w(*store, run);
    const nav::ImuSamples imu = samplesEvery(10, 0.1);
    ASSERT_TRUE(w.appendImu(imu).ok);
    calib::Segment seg;
    seg.t0 = 0.1;
    seg.t1 = 0.5;
    seg.label = "h1";
    ASSERT_TRUE(w.appendSegment(seg).ok);
    ASSERT_TRUE(w.flush().ok);
  }
  for (int step : {0, 1}) {
    RunEvent e{run, 1.0, EventSeverity::kInfo, "step_finished",
               "{\"step\":" + std::to_string(step) + "}"};
    ASSERT_TRUE(store->addEvent(e).ok);
  }
  EXPECT_FALSE(store->resumeRun(run).ok) << "a running run is not resumable";
  ASSERT_EQ(store->markInterruptedRuns().value, 1);
  const RunInfoResult info = store->runInfo(run);
  ASSERT_TRUE(info.status.ok);
  EXPECT_EQ(info.value.state, RunState::kInterrupted);
  EXPECT_NE(info.value.exit_reason.find("last stored sample at t = 1.0"), std::string::npos)
      << info.value.exit_reason;

  const ResumePoint point = store->resumePoint(run);
  ASSERT_TRUE(point.status.ok) << point.status.message;
  EXPECT_EQ(point.last_finished_step, 1);
  ASSERT_TRUE(point.last_imu_t && point.last_segment_t1);
  EXPECT_DOUBLE_EQ(*point.last_imu_t, 1.0);
  EXPECT_DOUBLE_EQ(*point.last_segment_t1, 0.5);
  EXPECT_FALSE(point.last_table_t);

  const Status resumed = store->resumeRun(run);
  ASSERT_TRUE(resumed.ok) << resumed.message;
  EXPECT_FALSE(store->resumeRun(run).ok) << "resumed twice";
  RunWriter w(*store, run, point);
  nav::ImuSample old;
  old.t = 1.0;
  EXPECT_FALSE(w.appendImu(std::span(&old, 1)).ok) << "a row at the stored end is refused";
  nav::ImuSample next;
  next.t = 5.0;
  ASSERT_TRUE(w.appendImu(std::span(&next, 1)).ok);
  ASSERT_TRUE(w.flush().ok);
  ASSERT_TRUE(store->finishRun(run, RunState::kFinished, "completed").ok);
  const auto rec = store->loadRecording(run);
  ASSERT_TRUE(rec.status.ok);
  EXPECT_EQ(rec.value.imu.size(), 11u);
  const EventListResult events = store->events(run);
  ASSERT_TRUE(events.status.ok);
  bool saw_resumed = false;
  for (const RunEvent& e : events.value) saw_resumed = saw_resumed || e.kind == "resumed";
  EXPECT_TRUE(saw_resumed);
}

// Issue 28 item 4: a rotation stored right before a gap is discarded while it is the newest
// segment; a second resume (it is gone already) never reaches an older segment of that label.
TEST(Store, TrailingSegmentsAreDiscardedOnlyWhileNewest) {
  ScratchDir dir("store");
  std::int64_t run = 0;
  auto store = storeWithRun(dir, "SN-G", &run);
  ASSERT_TRUE(store);
  {
    RunWriter w(*store, run);
    ASSERT_TRUE(w.appendImu(samplesEvery(10, 0.1)).ok);
    double t = 0.1;
    for (const char* label : {"r", "h1", "r"}) {
      calib::Segment seg;
      seg.t0 = t;
      seg.t1 = t + 0.2;
      seg.label = label;
      seg.kind =
          std::string(label) == "r" ? calib::SegmentKind::kRotate : calib::SegmentKind::kStatic;
      t += 0.3;
      ASSERT_TRUE(w.appendSegment(seg).ok);
    }
    ASSERT_TRUE(w.flush().ok);
  }
  auto labels = [&] {
    std::vector<std::string> out;
    for (const auto& s : store->loadRecording(run).value.segments) out.push_back(s.label);
    return out;
  };
  const CountResult first = store->discardTrailingSegments(run, {"r"});
  ASSERT_TRUE(first.status.ok) << first.status.message;
  EXPECT_EQ(first.value, 1);
  EXPECT_EQ(labels(), (std::vector<std::string>{"r", "h1"}));
  const CountResult again = store->discardTrailingSegments(run, {"r"});
  ASSERT_TRUE(again.status.ok);
  EXPECT_EQ(again.value, 0) << "the newest is h1 now: the older 'r' stays";
  EXPECT_EQ(labels(), (std::vector<std::string>{"r", "h1"}));
  int discarded_events = 0;
  for (const RunEvent& e : store->events(run).value)
    discarded_events += e.kind == "segments_discarded" ? 1 : 0;
  EXPECT_EQ(discarded_events, 1);
  EXPECT_EQ(store->loadRecording(run).value.imu.size(), 10u) << "every sample stays";
}

TEST(Store, UnknownRunIsAnError) {
  ScratchDir dir("store");
  auto store = openOrFail(dir.file("bench.db"));
  ASSERT_TRUE(store);
  const std::string missing = "run 42 not found";
  auto expectMissing = [&](const Status& st) {
    EXPECT_FALSE(st.ok);
    EXPECT_NE(st.message.find(missing), std::string::npos) << st.message;
  };
  expectMissing(store->runInfo(42).status);
  expectMissing(store->loadRecording(42).status);
  expectMissing(store->finishRun(42, RunState::kAborted, "x"));
  expectMissing(store->events(42).status);
  RunBatch batch;
  batch.imu.resize(1);
  expectMissing(store->appendBatch(42, batch));
  RunWriter writer(*store, 42);
  ASSERT_TRUE(writer.appendImu(batch.imu).ok);  // buffered: the error comes with the flush
  expectMissing(writer.flush());
  EXPECT_EQ(writer.bufferedRows(), 1u);
}

TEST(Store, NonFiniteAndUnorderedSamplesAreRefusedWithTheirIndex) {
  ScratchDir dir("store");
  std::int64_t run = 0;
  auto store = storeWithRun(dir, "SN-A", &run);
  ASSERT_TRUE(store);
  RunWriter writer(*store, run);
  nav::ImuSamples imu = samplesEvery(6, 0.001);
  imu[3].dvel.y() = std::numeric_limits<double>::quiet_NaN();
  Status st = writer.appendImu(imu);
  EXPECT_FALSE(st.ok);
  EXPECT_NE(st.message.find("IMU sample 3 has a non-finite value"), std::string::npos)
      << st.message;
  EXPECT_EQ(writer.bufferedRows(), 0u);  // nothing of a refused call is kept
  imu[3].dvel.y() = 0.0;
  imu[4].temp_c = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(writer.appendImu(imu).ok);
  imu[4].temp_c = std::numeric_limits<double>::quiet_NaN();  // not reported: fine
  ASSERT_TRUE(writer.appendImu(imu).ok);
  st = writer.appendImu(std::span(imu).subspan(5));  // same time again
  EXPECT_NE(st.message.find("IMU sample 0: time does not increase"), std::string::npos)
      << st.message;
  std::vector<io::TableSample> table(2);
  table[1].t = 1.0;
  table[1].angles_deg[2] = std::numeric_limits<double>::infinity();
  st = writer.appendTable(table);
  EXPECT_NE(st.message.find("table sample 1 has a non-finite value"), std::string::npos)
      << st.message;
  RunBatch batch;
  batch.chamber = {{0.0, 20.0, 20.0}, {1.0, std::nan(""), 20.0}};
  st = store->appendBatch(run, batch);
  EXPECT_NE(st.message.find("chamber sample 1 has a non-finite value"), std::string::npos)
      << st.message;
  ASSERT_TRUE(writer.flush().ok);
  const auto loaded = store->loadRecording(run);
  ASSERT_TRUE(loaded.status.ok);
  EXPECT_EQ(loaded.value.imu.size(), 6u);
  EXPECT_TRUE(std::isnan(loaded.value.imu[4].temp_c));
}

TEST(Store, CorruptFileIsRefusedNamingThePath) {
  ScratchDir dir("store");
  const std::string path = dir.file("garbage.db");
  {
    std::mt19937 rng(3);
    std::ofstream f(path, std::ios::binary);
    for (int i = 0; i < 16384; ++i) f.put(static_cast<char>(rng() & 0xff));
  }
  const auto r = Store::open(path);
  EXPECT_FALSE(r.status.ok);
  EXPECT_FALSE(r.value);
  EXPECT_EQ(r.status.message.rfind(path + ": ", 0), 0u) << r.status.message;
  EXPECT_NE(r.status.message.find("not an SQLite database"), std::string::npos) << r.status.message;
  std::cout << "corrupt file: " << r.status.message << "\n";

  const auto missing_dir = Store::open(dir.file("no/such/dir/bench.db"));
  EXPECT_FALSE(missing_dir.status.ok);
  EXPECT_NE(missing_dir.status.message.find("cannot open database"), std::string::npos)
      << missing_dir.status.message;
}

TEST(Store, ForeignDatabaseAndNewerSchemaAreRefused) {
  ScratchDir dir("store");
  const std::string foreign = dir.file("foreign.db");
  const std::string newer = dir.file("newer.db");
  ASSERT_TRUE(openOrFail(newer));
  for (const auto& [path, sql] :
       {std::pair{foreign, "CREATE TABLE x(a)"}, std::pair{newer, "PRAGMA user_version = 99"}}) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  const auto f = Store::open(foreign);
  EXPECT_FALSE(f.status.ok);
  EXPECT_NE(f.status.message.find(foreign + ": not an imubench store"), std::string::npos)
      << f.status.message;
  const auto n = Store::open(newer);
  EXPECT_FALSE(n.status.ok);
  EXPECT_NE(n.status.message.find(newer + ": schema version 99 is newer"), std::string::npos)
      << n.status.message;
}

QueueEntry queued(const std::string& name, const std::string& label = "") {
  QueueEntry e;
  e.plan_name = name;
  e.source = "/home/op/" + name + ".toml";
  e.plan_toml = "[plan]\nname = \"" + name + "\"\n";
  e.label = label;
  return e;
}

std::vector<std::string> queueNames(Store& store) {
  const QueueListResult list = store.queueList();
  EXPECT_TRUE(list.status.ok) << list.status.message;
  std::vector<std::string> names;
  for (const QueueEntry& e : list.value) names.push_back(e.plan_name);
  return names;
}

// Issue 15: the plan queue: add (at the end), list (in order), move, remove, and all of it
// still there after the store is closed and opened again.
TEST(StoreQueue, AddListMoveRemoveAndPersistAcrossReopen) {
  ScratchDir dir("store");
  const std::string path = dir.file("bench.db");
  std::vector<std::int64_t> ids;
  {
    auto store = openOrFail(path);
    ASSERT_TRUE(store);
    EXPECT_TRUE(store->queueList().value.empty());
    for (const char* name : {"a", "b", "c", "d"}) {
      const QueueAddResult r = store->queueAdd(queued(name, std::string("label ") + name));
      ASSERT_TRUE(r.status.ok) << r.status.message;
      EXPECT_EQ(r.value.position, static_cast<int>(ids.size()) + 1);
      ids.push_back(r.value.entry_id);
    }
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"a", "b", "c", "d"}));
    const QueueListResult list = store->queueList();
    EXPECT_EQ(list.value[1].id, ids[1]);
    EXPECT_EQ(list.value[1].source, "/home/op/b.toml");
    EXPECT_EQ(list.value[1].plan_toml, "[plan]\nname = \"b\"\n");
    EXPECT_EQ(list.value[1].label, "label b");
    EXPECT_GT(list.value[1].added_unix_s, 1.6e9);

    ASSERT_TRUE(store->queueMove(ids[3], 1).ok);  // d to the head
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "a", "b", "c"}));
    ASSERT_TRUE(store->queueMove(ids[0], 4).ok);  // a to the end
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "b", "c", "a"}));
    ASSERT_TRUE(store->queueMove(ids[2], 2).ok);
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "c", "b", "a"}));
    ASSERT_TRUE(store->queueRemove(ids[1]).ok);  // b
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "c", "a"}));

    // Refused, nothing changed: unknown entry, position out of range, removed entry.
    for (const auto& [st, text] :
         {std::pair{store->queueMove(9999, 1), "queue entry 9999 not found"},
          std::pair{store->queueMove(ids[0], 4), "position 4 is outside 1..3"},
          std::pair{store->queueMove(ids[0], 0), "position 0 is outside 1..3"},
          std::pair{store->queueRemove(ids[1]), "not found"}}) {
      EXPECT_FALSE(st.ok);
      EXPECT_NE(st.message.find(text), std::string::npos) << st.message;
      EXPECT_NE(st.message.find(path), std::string::npos) << st.message;
    }
    EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "c", "a"}));
  }
  auto store = openOrFail(path);
  ASSERT_TRUE(store);
  EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"d", "c", "a"}));
  // A new entry goes to the end and never reuses an id, even the largest one removed.
  ASSERT_TRUE(store->queueRemove(ids[3]).ok);
  const QueueAddResult e = store->queueAdd(queued("e"));
  ASSERT_TRUE(e.status.ok);
  EXPECT_GT(e.value.entry_id, ids[3]);
  EXPECT_EQ(e.value.position, 3);
  EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"c", "a", "e"}));
}

// A version 1 database (before the queue) is migrated when opened; its runs stay.
TEST(StoreQueue, Version1DatabaseIsMigrated) {
  ScratchDir dir("store");
  const std::string path = dir.file("v1.db");
  {
    auto store = openOrFail(path);
    ASSERT_TRUE(store);
    ASSERT_TRUE(store->beginRun(benchStart("SN-1")).status.ok);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(
      sqlite3_exec(db, "DROP TABLE queue; PRAGMA user_version = 1", nullptr, nullptr, nullptr),
      SQLITE_OK);
  sqlite3_close(db);
  auto store = openOrFail(path);
  ASSERT_TRUE(store);
  EXPECT_EQ(store->listRuns().value.size(), 1u);
  ASSERT_TRUE(store->queueAdd(queued("a")).status.ok);
  EXPECT_EQ(queueNames(*store), (std::vector<std::string>{"a"}));
  store.reset();
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &q, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(q), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(q, 0), kStoreSchemaVersion);
  sqlite3_finalize(q);
  sqlite3_close(db);
}

// Issue 30: a version 3 database (before the lab outbox) gets it. A store keeps no outbox until
// a mirror enables it; enabling enqueues what was stored, and from then on every change in the
// transaction that makes it.
TEST(Store, Version3DatabaseGetsTheLabOutbox) {
  ScratchDir dir("store");
  const std::string path = dir.file("v3.db");
  std::int64_t run = 0;
  {
    auto store = openOrFail(path);
    ASSERT_TRUE(store);
    run = store->beginRun(benchStart("SN-1")).value;
    ASSERT_GT(run, 0);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  std::string drop;
  for (const char* t :
       {"lab_run_insert", "lab_run_update", "lab_event_insert", "lab_result_insert",
        "lab_segment_insert", "lab_segment_delete", "lab_queue_insert", "lab_queue_delete"}) {
    drop += std::string("DROP TRIGGER ") + t + ";";
  }
  for (const char* v : {"lab_item_runs", "lab_item_events", "lab_item_results", "lab_item_segments",
                        "lab_item_queue"}) {
    drop += std::string("DROP VIEW ") + v + ";";
  }
  drop += "DROP TABLE lab_outbox; DROP TABLE lab_outbox_enabled; PRAGMA user_version = 3";
  ASSERT_EQ(sqlite3_exec(db, drop.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
  auto store = openOrFail(path);
  ASSERT_TRUE(store);
  ASSERT_TRUE(store->addEvent({run, 1.0, EventSeverity::kInfo, "note", "{}"}).ok);
  EXPECT_EQ(store->outboxBacklog().value, 0);  // not enabled: no outbox kept
  ASSERT_TRUE(store->enableOutbox().ok);
  EXPECT_EQ(store->outboxBacklog().value, 2);  // the run and its event
  ASSERT_TRUE(store->storeResult(run, "SN-1", 20.0, "report", "{\"a\": 1}").status.ok);
  const auto items = store->outboxPeek(10);
  ASSERT_TRUE(items.ok());
  ASSERT_EQ(items.value.size(), 3u);
  EXPECT_EQ(items.value[0].item, "run");
  EXPECT_EQ(items.value[2].item, "result/1");
  EXPECT_EQ(items.value[2].kind, "result");
  ASSERT_TRUE(store->outboxAck(items.value[1].seq).ok);
  EXPECT_EQ(store->outboxBacklog().value, 1);
}

// A version 2 database (before the round trips) gets the column; its table rows stay, their
// round trips unknown, and new rows store theirs.
TEST(Store, Version2DatabaseGetsRoundTrips) {
  ScratchDir dir("store");
  const std::string path = dir.file("v2.db");
  const io::Recording rec = makeRecording(5, calib::TableKind::kTwoAxis, 400);
  std::int64_t run = 0;
  {
    auto store = openOrFail(path);
    ASSERT_TRUE(store);
    const RunIdResult begun = store->beginRun(runStartFromRecording(rec));
    ASSERT_TRUE(begun.status.ok) << begun.status.message;
    run = begun.value;
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  // The version 2 table, with one row.
  ASSERT_EQ(sqlite3_exec(db,
                         "DROP TABLE table_samples; CREATE TABLE table_samples(run_id INTEGER "
                         "NOT NULL REFERENCES runs(id) ON DELETE CASCADE, t ANY NOT NULL, "
                         "angle0_deg ANY NOT NULL, angle1_deg ANY NOT NULL, angle2_deg ANY NOT "
                         "NULL, PRIMARY KEY(run_id, t)) STRICT, WITHOUT ROWID; INSERT INTO "
                         "table_samples VALUES(1, 0.5, 1.0, 2.0, 0.0); PRAGMA user_version = 2",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  auto store = openOrFail(path);
  ASSERT_TRUE(store);
  {
    RunWriter writer(*store, run, store->resumePoint(run));
    const io::TableSample later{1.0, {3.0, 4.0, 0.0}};
    const double rt = 0.021;
    ASSERT_TRUE(writer.appendTable(std::span(&later, 1), std::span(&rt, 1)).ok);
    ASSERT_TRUE(writer.flush().ok);
  }
  const TableRoundTripsResult trips = store->tableRoundTrips(run);
  ASSERT_TRUE(trips.status.ok) << trips.status.message;
  ASSERT_EQ(trips.value.size(), 2u);
  EXPECT_FALSE(trips.value[0].round_trip_s.has_value());
  ASSERT_TRUE(trips.value[1].round_trip_s.has_value());
  EXPECT_EQ(*trips.value[1].round_trip_s, 0.021);
  EXPECT_EQ(store->loadRecording(run).value.table.size(), 2u);
}

TEST(Store, OptionsAndRunStartAreValidated) {
  std::string why;
  EXPECT_TRUE(StoreOptions{}.IsValid(&why));
  StoreOptions o;
  o.max_unflushed_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_unflushed_s"), std::string::npos);
  ScratchDir dir("store");
  EXPECT_FALSE(Store::open(dir.file("bench.db"), o).status.ok);
  auto store = openOrFail(dir.file("bench.db"));
  ASSERT_TRUE(store);
  RunStart s = benchStart("SN-A");
  s.imu_rate_hz = 0.0;
  EXPECT_FALSE(store->beginRun(s).status.ok);
}

// ---------------------------------------------------------------------------------------
// kill -9 crash safety

constexpr double kImuRateHz = 2000.0;

// Sample k (1-based) of the crash test: exact values the parent can recompute.
nav::ImuSample crashSample(long k) {
  nav::ImuSample s;
  s.t = static_cast<double>(k) / kImuRateHz;
  s.dtheta = Vec3(1e-6, -2e-6, 3e-6) * static_cast<double>(k);
  s.dvel = Vec3(0.0, 0.0, 9.81 / kImuRateHz);
  s.temp_c = 25.0;
  return s;
}

bool writeAll(int fd, const void* data, size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w <= 0) return false;
    p += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

// Reads one progress record (a double); false at end of file (writer gone).
bool readProgress(int fd, double* t) {
  char* p = reinterpret_cast<char*>(t);
  size_t n = sizeof(double);
  while (n > 0) {
    const ssize_t r = ::read(fd, p, n);
    if (r <= 0) return false;
    p += r;
    n -= static_cast<size_t>(r);
  }
  return true;
}

// The forked writer: 20 samples every 10 ms of wall time (2 kHz, sample time = wall time),
// reporting the last appended sample time after each append. Never returns; exits only by
// the parent's SIGKILL (or with a code on failure), so no destructor flushes anything.
[[noreturn]] void crashWriterChild(const std::string& path, int progress_fd) {
  auto opened = Store::open(path);
  if (!opened.status.ok) _exit(2);
  const auto run = opened.value->beginRun(benchStart("KILL-9"));
  if (!run.status.ok) _exit(3);
  RunWriter writer(*opened.value, run.value);
  std::vector<nav::ImuSample> batch(20);
  const auto start = std::chrono::steady_clock::now();
  long k = 0;
  for (int tick = 1; tick <= 6000; ++tick) {  // 60 s cap if the parent never kills
    std::this_thread::sleep_until(start + std::chrono::milliseconds(10 * tick));
    for (auto& s : batch) s = crashSample(++k);
    if (!writer.appendImu(batch).ok) _exit(4);
    const double t = batch.back().t;
    if (!writeAll(progress_fd, &t, sizeof t)) _exit(5);
  }
  _exit(6);
}

struct CrashOutcome {
  double last_reported_t = 0.0;
  double last_stored_t = 0.0;
};

// Checks the reopened store after the kill: integrity, interrupted state, a gap-free prefix.
void checkAfterKill(const std::string& path, int expected_runs, CrashOutcome* out) {
  auto store = openOrFail(path);
  ASSERT_TRUE(store);
  const Status integrity = store->integrityCheck();
  ASSERT_TRUE(integrity.ok) << integrity.message;
  const CountResult marked = store->markInterruptedRuns();
  ASSERT_TRUE(marked.status.ok) << marked.status.message;
  EXPECT_EQ(marked.value, 1);
  const RunListResult runs = store->listRuns();
  ASSERT_TRUE(runs.status.ok);
  ASSERT_EQ(static_cast<int>(runs.value.size()), expected_runs);
  const RunInfo& run = runs.value.back();
  EXPECT_EQ(run.state, RunState::kInterrupted);
  const io::RecordingReadResult loaded = store->loadRecording(run.id);
  ASSERT_TRUE(loaded.status.ok) << loaded.status.message;
  const nav::ImuSamples& imu = loaded.value.imu;
  ASSERT_FALSE(imu.empty());
  for (size_t i = 0; i < imu.size(); ++i) {
    const nav::ImuSample want = crashSample(static_cast<long>(i + 1));
    ASSERT_TRUE(imu[i].t == want.t && imu[i].dtheta == want.dtheta && imu[i].dvel == want.dvel)
        << "stored sample " << i << " is not sample " << i + 1 << " (gap or corruption)";
  }
  out->last_stored_t = imu.back().t;
}

TEST(StoreCrash, KillNineLosesAtMostOneSecondOfSamples) {
  ScratchDir dir("store");
  const std::string path = dir.file("bench.db");
  std::mt19937 rng(::testing::UnitTest::GetInstance()->random_seed());
  std::uniform_real_distribution<double> kill_after_s(2.0, 3.0);
  constexpr int kRepeats = 3;
  for (int rep = 1; rep <= kRepeats; ++rep) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      crashWriterChild(path, fds[1]);
    }
    ::close(fds[1]);
    CrashOutcome outcome;
    const double kill_at_t = kill_after_s(rng);
    double t = 0.0;
    bool alive = true;
    while (outcome.last_reported_t < kill_at_t && (alive = readProgress(fds[0], &t)))
      outcome.last_reported_t = t;
    ::kill(pid, SIGKILL);
    int wstatus = 0;
    ASSERT_EQ(::waitpid(pid, &wstatus, 0), pid);
    // Progress written before the kill landed counts as appended too.
    while (readProgress(fds[0], &t)) outcome.last_reported_t = t;
    ::close(fds[0]);
    ASSERT_TRUE(alive) << "writer exited early, status " << wstatus;
    ASSERT_TRUE(WIFSIGNALED(wstatus) && WTERMSIG(wstatus) == SIGKILL);
    checkAfterKill(path, rep, &outcome);
    if (HasFatalFailure()) return;
    const double loss_s = outcome.last_reported_t - outcome.last_stored_t;
    std::cout << "kill -9 #" << rep << ": appended up to t=" << outcome.last_reported_t
              << " s, stored up to t=" << outcome.last_stored_t << " s, lost " << loss_s << " s\n";
    EXPECT_GE(loss_s, 0.0);
    EXPECT_LE(loss_s, 1.0);
  }
}

}  // namespace
}  // namespace imubench::daemon
