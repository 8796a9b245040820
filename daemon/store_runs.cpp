// The run store's runs (daemon/store.h): starting, ending, interruption and resume, the runs'
// events, and the discarding of segments a resumed run re-runs.
#include <sqlite3.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "daemon/store.h"
#include "daemon/store_internal.h"
#include "io/enum_names.h"

namespace imubench::daemon {
namespace {

// All runs (?1 NULL) or one; read by Store::Impl::readRun.
constexpr const char* kSelectRunsSql =
    "SELECT id, plan_name, plan_toml, bench_name, imu_serial, imu_rate_hz, latitude_deg, "
    "height_m, gravity_mps2, table_kind, outer_axis_heading_deg, segments_from_file, "
    "started_unix_s, finished_unix_s, state, exit_reason FROM runs "
    "WHERE ?1 IS NULL OR id = ?1 ORDER BY id";

const char* tableKindName(calib::TableKind kind) {
  return kind == calib::TableKind::kTwoAxis ? "two-axis" : "three-axis";
}

// An operator's abort is worth a warning; a fault is an error.
EventSeverity endSeverity(RunState state) {
  if (state == RunState::kFinished) return EventSeverity::kInfo;
  if (state == RunState::kAborted) return EventSeverity::kWarning;
  return EventSeverity::kError;
}

}  // namespace

using store_internal::Bound;
using store_internal::kLastImuTSql;
using store_internal::nowUnixS;
using store_internal::runLabel;

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

}  // namespace imubench::daemon
