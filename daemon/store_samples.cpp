// The run store's sample rows and segments going in (daemon/store.h): their checks, the batches
// of Store::appendBatch, RunWriter's buffering, and the import of a whole recording.
#include <sqlite3.h>

#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "daemon/store.h"
#include "daemon/store_internal.h"

namespace imubench::daemon {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

}  // namespace

using store_internal::Bound;
using store_internal::runLabel;
using store_internal::streamSql;

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

void RunBatch::clear() {
  imu.clear();
  table.clear();
  table_round_trip_s.clear();
  chamber.clear();
  segments.clear();
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
