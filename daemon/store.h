// Storage of bench runs in one SQLite database (the daemon's embedded default): the run's plan
// and meta data, its samples (IMU, table, chamber), segments, events, and calibration results.
//
// The database runs in WAL mode with synchronous=FULL: a committed transaction survives a
// crash of the process (kill -9) and a power loss (the WAL is synced at every commit). Samples
// are written in batches (RunWriter), one transaction per batch, so a killed daemon or a power
// loss loses at most the unflushed tail (StoreOptions::max_unflushed_s of sample time).
//
// loadRecording(run) rebuilds the exact io::Recording value (doubles bit-exact, -0.0 included), so
// writeRecording() exports a run as imubench-csv/1 and the calibrators run on a run id.
//
// Errors are returned as Status naming the database path; nothing here prints or throws.
// A Store is one connection and is not thread-safe; other processes may read concurrently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "io/recording.h"

namespace imubench::daemon {

// PRAGMA user_version of the schema this code writes. A database with a higher version was
// written by a newer imubench and is refused rather than misread; an older one is migrated
// when opened (1 -> 2: the plan queue's table; 2 -> 3: the table readings' round trips;
// 3 -> 4: the lab mirror's outbox).
inline constexpr int kStoreSchemaVersion = 4;

struct StoreOptions {
  // How long a statement waits for a lock held by another connection (a CLI reading while
  // the daemon writes, a checkpoint) before failing with "database is locked".
  int busy_timeout_ms = 5000;
  // RunWriter commits when its oldest buffered row is this much sample time older than the
  // newest: bounds what a kill -9 loses. 0.5 s is two commits per second, cheap for SQLite.
  double max_unflushed_s = 0.5;
  // RunWriter also commits at this many buffered rows (all kinds together), bounding memory
  // and transaction size for streams far faster than 2 kHz.
  std::size_t max_unflushed_rows = 20000;

  bool IsValid(std::string* why) const;
};

enum class RunState { kRunning, kFinished, kAborted, kFaulted, kInterrupted };
// "running", "finished", "aborted", "faulted", "interrupted" (the database's text form).
const char* runStateName(RunState state);
std::optional<RunState> runStateFromName(std::string_view name);
// `imubench resume RUN` applies: a run cut off by a crash or stop (interrupted), by the
// operator's abort or by a fault. A thermal run is hours of chamber time; an abort or a fault
// in one point must not throw away the points already done (issue 16). Running and finished
// runs are not resumable.
bool runResumable(RunState state);

// What is known when a run starts: the plan, the bench and the recording's meta data
// (io::Recording fields of the same name).
struct RunStart {
  std::string plan_name;
  std::string plan_toml;  // the plan file's text, so a run can be repeated exactly
  std::string bench_name;
  std::string imu_serial;
  double imu_rate_hz = 0.0;
  double latitude_deg = 0.0;
  double height_m = 0.0;
  std::optional<double> gravity_mps2;
  calib::TableKind table_kind = calib::TableKind::kTwoAxis;
  std::optional<double> outer_axis_heading_deg;  // two-axis only
  // io::Recording::segments_from_file: live runs log the plan's segments, so true.
  bool segments_from_file = true;

  bool IsValid(std::string* why) const;
};

// The meta data of `rec` as a RunStart (plan and bench names left empty).
RunStart runStartFromRecording(const io::Recording& rec);

struct RunInfo {
  std::int64_t id = 0;
  RunStart start;
  double started_unix_s = 0.0;            // wall clock, s since the Unix epoch
  std::optional<double> finished_unix_s;  // absent while running and for interrupted runs
  RunState state = RunState::kRunning;
  std::string exit_reason;
};

enum class EventSeverity { kInfo, kWarning, kError };
const char* eventSeverityName(EventSeverity severity);

struct RunEvent {
  std::int64_t run_id = 0;
  double wall_unix_s = 0.0;
  EventSeverity severity = EventSeverity::kInfo;
  std::string kind;  // short machine-readable tag, e.g. "interrupted", "table-fault"
  std::string json;  // details, a JSON text
};

// A plan waiting in the daemon's queue: started when the run before it completes. Stored, so
// the queue survives a daemon restart.
struct QueueEntry {
  std::int64_t id = 0;        // assigned by queueAdd, never reused
  std::string plan_name;      // the plan's own name ([plan] name)
  std::string source;         // what diagnostics call the plan (the client's file, a library path)
  std::string plan_toml;      // the plan's text as it was queued
  std::string label;          // the start's label (may be empty)
  double added_unix_s = 0.0;  // set by queueAdd
};

struct StoredResult {
  std::int64_t id = 0;
  std::int64_t run_id = 0;
  std::string imu_serial;
  double temperature_c = 0.0;
  std::string kind;  // e.g. "coefficients", "report"
  std::string json;
  double created_unix_s = 0.0;
};

// Empty fields match everything.
struct ResultFilter {
  std::optional<std::string> imu_serial;
  std::optional<std::int64_t> run_id;
};

// Rows of one run committed together (Store::appendBatch).
struct RunBatch {
  nav::ImuSamples imu;
  std::vector<io::TableSample> table;
  // Per table row, the round trip of the request that read it, s (NaN: unknown); empty when
  // none is known, else as long as `table`. Stored beside the row (table_samples.round_trip_s)
  // and never part of the recording: the imubench-csv/1 table.csv has no column for it
  // (interchange.md), so an export stays bit-exact.
  std::vector<double> table_round_trip_s;
  std::vector<io::ChamberSample> chamber;
  std::vector<calib::Segment> segments;

  std::size_t rows() const { return imu.size() + table.size() + chamber.size() + segments.size(); }
  void clear();
};

// One entry of the lab mirror's outbox (issue 30): an item keyed by (run_id, item) to upsert
// into (or delete from) the lab database. Written by triggers in the same transaction as the
// data it copies; payload is a JSON object (lab/shipper.h ships it).
struct OutboxItem {
  std::int64_t seq = 0;     // ships in this order; acknowledged up to a seq
  std::int64_t run_id = 0;  // 0: not of one run (the plan queue's history)
  std::string item;         // "run", "event/12", "result/3", "segment/4", "queue/7"
  std::string kind;         // run, event, result, segment, queue
  bool remove = false;      // a discarded segment: delete the item
  std::string payload;      // JSON object
};

// The raw sample streams the lab mirror may copy (issue 30, [lab] mirror_samples): the tables
// imu_samples, table_samples and chamber_samples. Each stream's rows of a run are keyed by
// their time t, strictly increasing; Store::appendBatch appends only after a stream's newest
// stored row, so "every row after t" is a complete, stable description of what is new.
enum class SampleStream { kImu, kTable, kChamber };
inline constexpr SampleStream kSampleStreams[] = {SampleStream::kImu, SampleStream::kTable,
                                                  SampleStream::kChamber};
const char* sampleStreamName(SampleStream stream);  // "imu", "table", "chamber"
// The stream's value columns after t, in stored order (their lab columns have the same names):
// imu dthx, dthy, dthz, dvx, dvy, dvz, temp_c; table angle0_deg, angle1_deg, angle2_deg,
// round_trip_s; chamber setpoint_c, temp_c.
std::span<const char* const> sampleColumns(SampleStream stream);

// Rows of one stream of one run (Store::readSamples): row i is t[i] and
// values[i * columns .. + columns) (sampleColumns order; NaN where the store holds NULL).
struct SampleRows {
  SampleStream stream = SampleStream::kImu;
  std::size_t columns = 0;
  std::vector<double> t;
  std::vector<double> values;
  std::size_t size() const { return t.size(); }
};

// The newest stored row of one stream of one run.
struct SampleTail {
  std::int64_t run_id = 0;
  SampleStream stream = SampleStream::kImu;
  double newest_t = 0.0;
};

class Store;

// What the store's calls return: the status and, when ok(), the payload in `value`.
using StoreOpenResult = Result<std::unique_ptr<Store>>;
using RunIdResult = Result<std::int64_t>;
using RunInfoResult = Result<RunInfo>;
using RunListResult = Result<std::vector<RunInfo>>;     // by id
using EventListResult = Result<std::vector<RunEvent>>;  // in insertion order
using ResultIdResult = Result<std::int64_t>;
using ResultListResult = Result<std::vector<StoredResult>>;  // by id
struct QueuePlace {
  std::int64_t entry_id = 0;
  int position = 0;  // 1-based: where it landed (the last place)
};
using QueueAddResult = Result<QueuePlace>;
using QueueListResult = Result<std::vector<QueueEntry>>;  // in queue order, the next first
using CountResult = Result<int>;
using OutboxListResult = Result<std::vector<OutboxItem>>;   // by seq
using SampleTailsResult = Result<std::vector<SampleTail>>;  // by run, then stream
using SampleRowsResult = Result<SampleRows>;
using SampleCountResult = Result<std::int64_t>;
struct TableRoundTrip {
  double t = 0.0;                      // the reading's time (table_samples.t)
  std::optional<double> round_trip_s;  // unset: unknown
};
using TableRoundTripsResult = Result<std::vector<TableRoundTrip>>;
// Where an interrupted run stands (Store::resumePoint): the step of the newest stored
// step_finished event (its segment is committed before the event), and the newest stored row of
// each stream, so the resumed run's rows continue after them.
struct ResumePoint {
  Status status;
  int last_finished_step = -1;  // -1: no step finished yet
  std::optional<double> last_imu_t;
  std::optional<double> last_table_t;
  std::optional<double> last_chamber_t;
  std::optional<double> last_segment_t1;
};

class Store {
 public:
  // Creates the database (and its schema) or opens an existing one. Refuses a file that is
  // not an imubench store, a corrupted one, and a schema newer than kStoreSchemaVersion.
  static StoreOpenResult open(const std::string& path, const StoreOptions& options = {});

  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  const std::string& path() const;
  const StoreOptions& options() const;

  // A new run in state running, started now.
  RunIdResult beginRun(const RunStart& start);
  // Ends a running run; `state` must not be kRunning.
  Status finishRun(std::int64_t run_id, RunState state, const std::string& reason);
  // Daemon start-up: every run still `running` was cut off by a crash or kill; it becomes
  // `interrupted` with an event naming the time of its last stored IMU sample. Returns how many.
  CountResult markInterruptedRuns();
  // An interrupted, aborted or faulted run goes on (imubench resume RUN): back to `running`,
  // with a "resumed" event. Refuses any other state (runResumable).
  Status resumeRun(std::int64_t run_id);
  // The checkpoint an interrupted run resumes from.
  ResumePoint resumePoint(std::int64_t run_id);
  // A resumed run restarts an interrupted temperature point at its chamber step
  // (daemon/plan_runner.h resumeStep): the segments of that point's steps that had finished
  // are forgotten (they re-run at the setpoint; otherwise the calibration would see them twice),
  // from the newest segment labelled `label` (the point's first step) on, with a
  // "segments_discarded" event. Every sample row stays. Returns how many segments went; 0
  // when none is labelled `label` (the step never finished). Call before resumePoint.
  CountResult discardSegmentsFrom(std::int64_t run_id, const std::string& label);
  // A rotation stored right before a gap in the recording lost its hold after
  // (daemon/plan_runner.h gapRestart): the run's newest segments are discarded while they carry
  // `labels` from the last backwards (labels in step order: the newest segment must be
  // labels.back(), the one before it the label before, ...); the first that does not match
  // stops it (a segment discarded already is never matched against an older one of the same
  // label). With a "segments_discarded" event when any went; every sample row stays. Returns
  // how many went.
  CountResult discardTrailingSegments(std::int64_t run_id, const std::vector<std::string>& labels);
  RunListResult listRuns();
  RunInfoResult runInfo(std::int64_t run_id);

  // Commits the rows in one transaction. Refuses (nothing written) non-finite values and rows
  // not after their stream's newest stored row (times only grow: what the lab mirror's sample
  // shipping relies on), naming the row; IMU temp_c may be NaN (not reported).
  Status appendBatch(std::int64_t run_id, const RunBatch& batch);

  Status addEvent(const RunEvent& event);  // json must be valid JSON
  EventListResult events(std::int64_t run_id);

  // A whole recording as one finished run (import of an imubench-csv/1 directory).
  RunIdResult importRecording(const RunStart& start, const io::Recording& rec);
  // The run's samples and meta data as a io::Recording (also for a running or interrupted run:
  // what has been committed).
  io::RecordingReadResult loadRecording(std::int64_t run_id);
  // The run's table readings' round trips in time order (the rows of loadRecording's table):
  // how long the request that read each took (the daemon stamps a reading at its midpoint, so
  // its time is within half of it); unset where unknown (an import, a driver without it).
  TableRoundTripsResult tableRoundTrips(std::int64_t run_id);

  ResultIdResult storeResult(std::int64_t run_id, const std::string& imu_serial,
                             double temperature_c, const std::string& kind,
                             const std::string& json_text);
  ResultListResult results(const ResultFilter& filter = {});

  // The plan queue. Positions are 1-based, the head (position 1) starts next.
  QueueAddResult queueAdd(const QueueEntry& entry);  // appended at the end
  QueueListResult queueList();
  // Moves an entry to `position` (1..size); the others keep their order. Refuses an unknown
  // entry or a position out of range (nothing changes).
  Status queueMove(std::int64_t entry_id, int position);
  Status queueRemove(std::int64_t entry_id);  // refuses an unknown entry

  // The lab mirror's outbox (OutboxItem). enableOutbox is idempotent: the first call enqueues
  // everything already stored and from then on every change of runs, events, results, segments
  // and the queue enqueues its item in the same transaction. A store that never enabled it
  // keeps no outbox. Another connection (the shipper's) may peek and acknowledge concurrently.
  Status enableOutbox();
  OutboxListResult outboxPeek(std::size_t limit);  // the oldest `limit` entries
  Status outboxAck(std::int64_t up_to_seq);        // the lab committed every seq <= up_to_seq
  CountResult outboxBacklog();                     // entries not yet acknowledged

  // The raw samples for the lab mirror (SampleStream). Read-only: what was shipped is recorded
  // in the lab database, in the transaction that ships it (lab/sample_shipper.h).
  // Every run's and stream's newest row (streams without rows left out).
  SampleTailsResult sampleTails();
  // Up to `limit` rows of the stream after time `after_t` (all when unset), in time order, read
  // in one statement (one snapshot).
  SampleRowsResult readSamples(std::int64_t run_id, SampleStream stream,
                               std::optional<double> after_t, std::size_t limit);
  // How many rows of the stream come after `after_t` (all when unset).
  SampleCountResult countSamples(std::int64_t run_id, SampleStream stream,
                                 std::optional<double> after_t);

  // PRAGMA integrity_check: ok, or the problems it lists.
  Status integrityCheck();

 private:
  struct Impl;
  explicit Store(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Buffers one run's rows during the run and commits them through Store::appendBatch when the
// oldest buffered row is options().max_unflushed_s of sample time older than the newest, or
// when max_unflushed_rows are buffered. Each append checks its rows (finite, times strictly
// increasing per stream) and refuses the whole call, naming the row index, before buffering.
// The store must outlive the writer.
class RunWriter {
 public:
  RunWriter(Store& store, std::int64_t run_id);
  // A resumed run: its new rows must come after what is stored (point from resumePoint).
  RunWriter(Store& store, std::int64_t run_id, const ResumePoint& point);
  // Best-effort flush; call flush() first to see its status.
  ~RunWriter();
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;

  Status appendImu(std::span<const nav::ImuSample> samples);
  // round_trip_s: empty (unknown) or one per sample (RunBatch::table_round_trip_s).
  Status appendTable(std::span<const io::TableSample> samples,
                     std::span<const double> round_trip_s = {});
  Status appendChamber(std::span<const io::ChamberSample> samples);
  Status appendSegment(const calib::Segment& segment);

  // Flushes when the oldest buffered row is max_unflushed_s older than `now_t` (sample
  // clock): a timer calls this so a stalled stream does not hold rows back.
  Status flushIfDue(double now_t);
  Status flush();

  std::size_t bufferedRows() const { return buffer_.rows(); }
  std::int64_t runId() const { return run_id_; }

 private:
  Status buffered(double oldest_new_t, double newest_t);
  // Checks rows of one stream (finite, time increasing past *last_t), then buffers them.
  template <class Row>
  Status appendRows(const char* what, std::span<const Row> rows, std::optional<double>* last_t,
                    std::vector<Row>* buffer);

  Store* store_;
  std::int64_t run_id_;
  RunBatch buffer_;
  std::optional<double> oldest_buffered_t_;
  std::optional<double> last_imu_t_;
  std::optional<double> last_table_t_;
  std::optional<double> last_chamber_t_;
  std::optional<double> last_segment_t1_;
};

}  // namespace imubench::daemon
