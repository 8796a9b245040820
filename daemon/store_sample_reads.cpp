// The run store's sample rows coming out (daemon/store.h): a run as an io::Recording, its table
// readings' round trips, and the raw sample streams the lab mirror copies (SampleStream).
#include <sqlite3.h>

#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "daemon/store.h"
#include "daemon/store_internal.h"

namespace imubench::daemon {
namespace {

std::optional<calib::SegmentKind> segmentKindFromName(std::string_view name) {
  for (auto k : {calib::SegmentKind::kStatic, calib::SegmentKind::kRotate,
                 calib::SegmentKind::kMove, calib::SegmentKind::kSoak}) {
    if (name == calib::segmentKindName(k)) return k;
  }
  return std::nullopt;
}

}  // namespace

namespace store_internal {

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

}  // namespace store_internal

using store_internal::Bound;
using store_internal::runLabel;
using store_internal::StreamSql;
using store_internal::streamSql;

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

}  // namespace imubench::daemon
