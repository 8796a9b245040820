// BenchDaemon: the IMU and the table (intake, polling, steps, run events, status); the parts
// are listed at the top of daemon/bench_daemon.cpp.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/bench_daemon.h"
#include "daemon/bench_daemon_internal.h"
#include "daemon/imu_clock.h"
#include "daemon/thermal_points.h"

namespace imubench::daemon {

using bench_daemon_internal::unixNow;
using nlohmann::json;

namespace {

// A runner event as its protocol event (daemon/control_protocol.h); exit: the run's, if ended.
json runnerEventFields(const RunnerEvent& e, std::int64_t run, RunExit exit) {
  const StepRef at{run, e.step, e.label};
  switch (e.kind) {
    case RunnerEvent::Kind::kState: {
      RunStateEvent ev{at, e.message, std::nullopt};
      if (exit != RunExit::kNone) ev.exit = runExitName(exit);  // how a run ended
      return toJson(ev);
    }
    case RunnerEvent::Kind::kStepStarted:
      return toJson(StepStartedEvent{at});
    case RunnerEvent::Kind::kStepFinished:
      return toJson(StepFinishedEvent{at});
    case RunnerEvent::Kind::kAlarm:
      return toJson(AlarmEvent{at, e.message});
    case RunnerEvent::Kind::kSoakSettled:
    case RunnerEvent::Kind::kSoakTimeout:
      return toJson(SoakEvent{at, e.kind == RunnerEvent::Kind::kSoakSettled, e.message});
    case RunnerEvent::Kind::kPointRestarted:
      return toJson(AlarmEvent{at, e.message});
  }
  return toJson(at);
}

}  // namespace

// ---- IMU and table ------------------------------------------------------------------------

// The IMU's frames wait in the socket while the loop talks to the devices (a table poll is 8
// round trips: 0.17 s at 20 ms Modbus latency, 640 frames of a 200 Hz IMU at 20x). One batch
// (drivers::ImuCanReader, 256 frames) per wake fell behind until the socket dropped frames;
// up to kImuBatchesPerWake batches drain it, and the bound keeps the loop's other work (the
// stop socket first) waiting for at most that many.
void BenchDaemon::onImuReadable() {
  for (int k = 0; k < kImuBatchesPerWake && readImuBatch(); ++k) {
  }
}

// One batch of IMU frames: stored, stamping the pending table reading, closing steps. False
// when nothing was read.
bool BenchDaemon::readImuBatch() {
  decoded_.clear();
  if (auto st = imu_->poll(0, &decoded_); !st.ok) {
    limited_.report("IMU", LogLevel::kError, "IMU: " + st.message, wallNow());
    return false;
  }
  reportImuProblems();
  if (decoded_.empty()) return false;
  imu_last_t_ = decoded_.back().sample.t;
  imu_last_wall_s_ = wallNow();
  // The IMU's own temperature (auto soaks watch it): the newest frame's, none when it has none.
  imu_last_temp_c_.reset();
  if (std::isfinite(decoded_.back().sample.temp_c))
    imu_last_temp_c_ = decoded_.back().sample.temp_c;
  if (!run_) return true;
  samples_.clear();
  for (const auto& d : decoded_) samples_.push_back(d.sample);
  if (auto st = run_->writer->appendImu(samples_); !st.ok) {
    log_.error("store: " + st.message);
    return true;
  }
  // A closing step ends at the first sample received after the table reading that ended it
  // (a frame without a kernel receive time: at once) and, after a motion, once the IMU itself
  // senses the table still: a sender that lags the table sends the motion's end later.
  std::size_t first = 0;
  for (std::size_t i = 0; i < decoded_.size(); ++i) {
    const bool burst_end =
        i + 1 == decoded_.size() ||
        decoded_[i + 1].rx_time_s - decoded_[i].rx_time_s > ActiveRun::kBurstGapS;
    checkImuGap(i);
    stampPendingTable(decoded_[i], burst_end);
    run_->trackStillness(decoded_[i].sample);
    if (!run_->closing) continue;
    const double rx = decoded_[i].rx_time_s;
    if (rx > 0.0 && rx <= run_->closing->after_unix_s) continue;
    const calib::SegmentKind kind =
        run_->runner->steps()[static_cast<std::size_t>(run_->closing->step)].kind;
    const bool motion = kind == calib::SegmentKind::kMove || kind == calib::SegmentKind::kRotate;
    if (motion && !run_->imuStill()) continue;
    if (run_->engine) run_->engine->addImu(std::span(samples_).subspan(first, i + 1 - first));
    first = i + 1;
    closeStep(decoded_[i].sample.t);
  }
  if (run_->engine) run_->engine->addImu(std::span(samples_).subspan(first));
  return true;
}

// A gap in the IMU stream before decoded_[i] (a step longer than kGapPeriods sample periods, or
// the largest step of the batch in which the decoder saw a restart) voids the segments it
// touches: onRecordingGap.
void BenchDaemon::checkImuGap(std::size_t i) {
  ActiveRun& run = *run_;
  const double t = decoded_[i].sample.t;
  const std::optional<double> prev = run.last_sample_t;
  run.last_sample_t = t;
  if (!prev) return;
  const double period = bench_.imu.layout.sample_period_s;
  bool gap = t - *prev > kGapPeriods * period;
  std::string cause = "IMU samples missing";
  if (run.imu_restarted) {
    double largest = t - *prev;
    for (std::size_t k = i + 1; k < decoded_.size(); ++k)
      largest = std::max(largest, decoded_[k].sample.t - decoded_[k - 1].sample.t);
    if (t - *prev >= largest) {  // the restart's step
      run.imu_restarted = false;
      gap = true;
      cause = "the IMU restarted";
    }
  }
  if (!gap) return;
  run.last_table_read.reset();  // the readings it held back are this gap's
  onRecordingGap(*prev, t, "IMU data", cause);
}

// The IMU stream or the table readings (`what`) have a gap from t_a to t_b inside the run: a
// step whose segment would span it runs again (its segment void), and so do the steps
// gapRestart names (no rotation next to a gap); an alarm says so. A soak is not repeated (its
// segment stays; the calibration leaves it out: online_engine.h completeSegmentsOnly). Nothing
// re-runs once the run is ending. A gap of the IMU stream holds the table readings back too:
// the table's gap across it is this one.
void BenchDaemon::onRecordingGap(double t_a, double t_b, const std::string& what,
                                 const std::string& cause) {
  ActiveRun& run = *run_;
  PlanRunner& r = *run.runner;
  const auto& steps = r.steps();
  if (r.state() != RunnerState::kRunning && r.state() != RunnerState::kPaused) return;
  const int open_step = run.closing ? run.closing->step : r.currentStep();
  const bool open = run.closing || run.segment_t0;
  if (open_step >= 0 && open_step < static_cast<int>(steps.size()) &&
      steps[static_cast<std::size_t>(open_step)].kind == calib::SegmentKind::kSoak) {
    recordGap(run.id, t_a, t_b,
              cause + "; inside soak '" + steps[static_cast<std::size_t>(open_step)].label +
                  "', which goes on",
              steps, GapRestart{r.currentStep(), r.currentStep()});
    return;
  }
  run.closing.reset();  // its segment would end after the gap: void, and so is its checkpoint
  run.segment_t0.reset();
  const GapRestart g = gapRestart(steps, run.last_stored_step);
  if (!open && g.step >= r.currentStep()) {  // nothing recorded across it, no rotation next to it
    recordGap(run.id, t_a, t_b, cause, steps, GapRestart{r.currentStep(), r.currentStep()});
    return;
  }
  if (auto fl = run.writer->flush(); !fl.ok) log_.error("store: " + fl.message);
  if (g.first_void <= run.last_stored_step) {
    if (auto st = discardVoidSegments(run.id, steps, g, run.last_stored_step, false); !st.ok)
      log_.error("store: " + st.message);
    run.last_stored_step = g.first_void - 1;
  }
  recordGap(run.id, t_a, t_b, cause, steps, g);
  const std::string label = steps[static_cast<std::size_t>(g.step)].label;
  std::ostringstream why;
  why << what << " gap of " << (t_b - t_a) << " s at t = " << t_a << " s (" << cause
      << ") inside the run: the steps from '" << label << "' run again";
  if (auto st = r.repeatFrom(g.step, wallNow(), why.str()); !st.ok)
    log_.error("run " + std::to_string(run.id) + ": " + st.message);
  publish(r.takeEvents());
}

// Lost samples go to the log; a restart also to the run's event log and the socket.
void BenchDaemon::reportImuProblems() {
  const drivers::ImuDecoder& decoder = imu_->decoder();
  const auto& counters = decoder.counters();
  if (counters.lost_samples > imu_lost_reported_) {
    limited_.report("IMU lost samples", LogLevel::kWarning,
                    "IMU: " + std::to_string(counters.lost_samples - imu_lost_reported_) +
                        " sample(s) lost: " + decoder.lastProblem(),
                    wallNow());
    imu_lost_reported_ = counters.lost_samples;
  }
  if (counters.restarts == imu_restarts_reported_) return;
  imu_restarts_reported_ = counters.restarts;
  limited_.report("IMU restart", LogLevel::kWarning, decoder.lastRestart(), wallNow());
  ImuRestartEvent event{counters.restarts, decoder.lastRestart(), std::nullopt};
  if (run_) run_->imu_restarted = true;
  if (run_) {
    event.run = run_->id;
    RunEvent stored;
    stored.run_id = run_->id;
    stored.wall_unix_s = unixNow();
    stored.severity = EventSeverity::kWarning;
    stored.kind = ImuRestartEvent::kEvent;
    stored.json = toJson(event).dump();
    if (auto st = store_->addEvent(stored); !st.ok) log_.error("store: " + st.message);
  }
  server_->broadcast(event);
}

// The table is polled whenever the daemon runs: the status shows the controller as it is
// (a stop, a front panel, a restart) within a poll, and every poll feeds the controller's
// host watchdog (drivers::TableDriver::read writes the heartbeat).
void BenchDaemon::onPoll() {
  if (!run_) {
    const BenchObservation obs = port_->observe(wallNow(), imu_last_wall_s_);
    if (obs.table_ok) table_answered_s_ = wallNow();
    return;
  }
  // Frames already in the socket count before the IMU's silence is judged (the loop may have
  // been held up, and the poll timer may be served before the socket in one wake).
  onImuReadable();
  if (!run_) return;
  run_->poll_unix_s = unixNow();  // before the table is read: see closeStep
  BenchObservation obs = port_->observe(wallNow(), imu_last_wall_s_);
  obs.plan_time_s = imu_last_t_;
  obs.imu_temp_c = imu_last_temp_c_;
  if (obs.table_ok) table_answered_s_ = wallNow();
  if (obs.table_ok) {
    // a reading no sample has stamped yet is superseded
    const double replied = unixNow();
    run_->pending_table =
        run_->reading(obs, 0.5 * (run_->poll_unix_s + replied), replied - run_->poll_unix_s);
  }
  run_->runner->tick(obs);
  publish(run_->runner->takeEvents());
  if (run_ && imu_last_t_) run_->writer->flushIfDue(*imu_last_t_);
  if (run_ && (run_->runner->state() == RunnerState::kFinished ||
               run_->runner->state() == RunnerState::kFaulted)) {
    closeRun();
  }
}

// The pending table reading gets its IMU time (see ActiveRun::PendingTable) once d, the last of
// its burst, was received after the reading, and is stored.
void BenchDaemon::stampPendingTable(const drivers::DecodedImuSample& d, bool burst_end) {
  ActiveRun& run = *run_;
  const double rx = d.rx_time_s;
  const double t = d.sample.t;
  if (rx > 0.0 && !burst_end) return;
  if (rx > 0.0) run.clock.addAnchor(rx, t);
  if (run.pending_table && (rx <= 0.0 || rx >= run.pending_table->read.at_unix_s)) {
    io::TableSample ts = run.pending_table->sample;
    ts.t = t;
    const std::optional<ImuClockLine> line =
        rx > 0.0 ? run.clock.line() : std::optional<ImuClockLine>();
    if (line) {
      ts.t = line->imuTime(run.pending_table->read.at_unix_s);
      for (std::size_t a = 0; a < 3; ++a) {  // each axis to the reading's instant
        const double t_axis = line->imuTime(run.pending_table->read_unix_s[a]);
        ts.angles_deg[a] += run.pending_table->rate[a] * (ts.t - t_axis) * kRadToDeg;
      }
    } else if (rx > 0.0 && run.last_rx_unix_s && rx > *run.last_rx_unix_s) {
      const double f =
          (run.pending_table->read.at_unix_s - *run.last_rx_unix_s) / (rx - *run.last_rx_unix_s);
      ts.t = *run.last_rx_t + std::clamp(f, 0.0, 1.0) * (t - *run.last_rx_t);
    }
    const TableReadTiming read = run.pending_table->read;
    run.pending_table.reset();
    storeTableSample(ts, read);
  }
  if (rx > 0.0) {
    run.last_rx_unix_s = rx;
    run.last_rx_t = t;
  }
}

// A stamped table reading goes to the store (with its read round trip) and the online engine,
// in time order. Readings further apart than the bench's [table] reading_gap while the plan runs:
// onRecordingGap.
void BenchDaemon::storeTableSample(const io::TableSample& ts, const TableReadTiming& read) {
  ActiveRun& run = *run_;
  if (run.last_table_t && ts.t <= *run.last_table_t) return;
  if (auto st = run.writer->appendTable(std::span(&ts, 1), std::span(&read.round_trip_s, 1));
      !st.ok) {
    log_.error("store: " + st.message);
  } else if (run.engine) {
    run.engine->addTable(ts);
  }
  const std::optional<double> prev_t = run.last_table_t;
  const std::optional<TableReadTiming> prev = run.last_table_read;
  const double cadence_s = std::max(options_.table_poll_s, run.typicalPollS(read.poll_duration_s));
  run.addPollDuration(read.poll_duration_s);
  run.last_table_t = ts.t;
  run.last_table_read = read;
  if (!prev_t || !prev || run.runner->state() != RunnerState::kRunning) return;
  const double busy_s = read.busy_s - prev->busy_s;
  const double apart_s = read.at_unix_s - prev->at_unix_s;
  if (apart_s - busy_s <= cadence_s + bench_.table_reading_gap_s) return;
  std::ostringstream cause;
  cause << "table readings " << apart_s << " s apart (wall clock; a poll takes " << cadence_s
        << " s, device commands took " << busy_s << " s meanwhile, gap threshold "
        << bench_.table_reading_gap_s << " s beyond them)";
  onRecordingGap(*prev_t, ts.t, "table data", cause.str());
}

// A step's segment and the online engine's view of it begin at IMU time t0.
void BenchDaemon::beginStep(int step, std::optional<double> t0) {
  run_->segment_t0 = t0;
  if (run_->engine)
    run_->engine->stepStarted(step, run_->runner->steps()[static_cast<std::size_t>(step)].kind);
}

// The closing step's segment ends at IMU time t1 (stored; the online engine's step statistics
// published as event "step_stats"), and the step that began meanwhile starts there.
void BenchDaemon::closeStep(std::optional<double> t1) {
  const ActiveRun::ClosingStep c = *run_->closing;
  run_->closing.reset();
  const RunStep& s = run_->runner->steps()[static_cast<std::size_t>(c.step)];
  std::optional<calib::Segment> stored_segment;
  if (run_->segment_t0 && t1 && *t1 > *run_->segment_t0) {
    calib::Segment seg;
    seg.t0 = *run_->segment_t0;
    seg.t1 = *t1;
    seg.kind = s.kind;
    seg.label = s.label;
    seg.recording = s.recording;
    seg.axis = s.axis;
    seg.angle = s.delta;
    if (auto st = run_->writer->appendSegment(seg); !st.ok) {
      log_.error("store: " + st.message);
    } else {
      stored_segment = seg;
      run_->last_stored_step = c.step;
      if (auto fl = run_->writer->flush(); !fl.ok) log_.error("store: " + fl.message);
    }
  } else {
    log_.warning("run " + std::to_string(run_->id) + ": step '" + c.label +
                 "' ended before an IMU sample after its start: no segment stored");
  }
  // The checkpoint after the segment it vouches for (samples and segment committed above).
  if (auto st = store_->addEvent(c.finished); !st.ok) log_.error("store: " + st.message);
  if (run_->engine) {
    const json stats = run_->engine->stepFinished(stored_segment, c.label);
    server_->broadcast(Topic::kRun, "step_stats",
                       {{"run", run_->id}, {"step", c.step}, {"label", c.label}, {"stats", stats}});
  }
  if (c.next_step) beginStep(*c.next_step, t1);
}

// Runner events: a segment per finished step, the run's event log, subscribers, syslog.
// A step's segment ends at the first IMU sample received after the table reading that showed
// the step done (closeStep from onImuReadable): IMU frames may arrive later than the table's
// replies, and a segment cut at the newest sample then would miss the motion's end.
void BenchDaemon::publish(const std::vector<RunnerEvent>& events) {
  for (const RunnerEvent& e : events) {
    const json fields = runnerEventFields(e, run_->id, run_->runner->exit());
    const char* name = runnerEventKindName(e.kind);
    if (e.kind == RunnerEvent::Kind::kPointRestarted) discardPoint(e);
    if (e.kind == RunnerEvent::Kind::kStepStarted) {
      if (run_->closing) {
        run_->closing->next_step = e.step;  // begins where the closing step's segment ends
      } else {
        beginStep(e.step, imu_last_t_);
      }
    }
    RunEvent stored;
    stored.run_id = run_->id;
    stored.wall_unix_s = unixNow();
    stored.severity =
        e.kind == RunnerEvent::Kind::kAlarm || e.kind == RunnerEvent::Kind::kSoakTimeout
            ? EventSeverity::kWarning
            : EventSeverity::kInfo;
    stored.kind = name;
    stored.json = fields.dump();
    if (e.kind == RunnerEvent::Kind::kStepFinished) {
      // The stored step_finished event is the crash-resume checkpoint: it is stored by
      // closeStep after the step's samples and its segment (which ends with the next IMU
      // sample), so a kill -9 before that repeats the step instead of losing its segment.
      if (run_->closing) closeStep(imu_last_t_);  // two steps in one poll: no wait for the first
      run_->closing =
          ActiveRun::ClosingStep{e.step, e.label, run_->poll_unix_s, std::nullopt, stored};
    } else if (auto st = store_->addEvent(stored); !st.ok) {
      log_.error("store: " + st.message);
    }
    server_->broadcast(Topic::kRun, name, fields);
    if (e.kind == RunnerEvent::Kind::kAlarm) {
      limited_.report("run alarms", LogLevel::kWarning,
                      "run " + std::to_string(run_->id) + ": ALARM: " + e.message, wallNow());
    } else if (e.kind == RunnerEvent::Kind::kState) {
      log_.info("run " + std::to_string(run_->id) + ": " + e.message);
    }
  }
}

// The runner restarts a temperature point (plan_runner.h kPointRestarted): the segments its
// steps stored are void (they run again); the pending step is closed first, the rows flushed.
void BenchDaemon::discardPoint(const RunnerEvent& e) {
  if (run_->closing) closeStep(imu_last_t_);
  if (auto st = run_->writer->flush(); !st.ok) log_.error("store: " + st.message);
  const auto& steps = run_->runner->steps();
  if (e.step < 0 || e.step >= static_cast<int>(steps.size())) return;
  const CountResult r =
      store_->discardSegmentsFrom(run_->id, steps[static_cast<std::size_t>(e.step)].label);
  if (!r.status.ok) log_.error("store: " + r.status.message);
  run_->last_stored_step = e.step - 1;
}

// The chamber on its own timer: its reading for the runner's next ticks, and a chamber
// sample of the run stamped with the newest IMU time.
void BenchDaemon::onChamberPoll() {
  if (!run_ || !chamber_) return;
  drivers::ChamberReading c;
  if (!port_->readChamber(&c) || !imu_last_t_) return;
  if (run_->last_chamber_t && !(*imu_last_t_ > *run_->last_chamber_t)) return;
  io::ChamberSample cs;
  cs.t = *imu_last_t_;
  cs.setpoint_c = c.setpoint_c;
  cs.temp_c = c.temperature_c;
  if (auto st = run_->writer->appendChamber(std::span(&cs, 1)); !st.ok) {
    log_.error("store: " + st.message);
  }
  run_->last_chamber_t = cs.t;
}

void BenchDaemon::closeRun() {
  if (run_->closing) closeStep(imu_last_t_);
  PlanRunner& r = *run_->runner;
  if (auto st = run_->writer->flush(); !st.ok) log_.error("store: " + st.message);
  RunState state = RunState::kFaulted;
  std::string reason = runExitName(r.exit());
  if (r.exit() == RunExit::kCompleted) state = RunState::kFinished;
  if (r.exit() == RunExit::kAborted) state = RunState::kAborted;
  if (r.state() == RunnerState::kAborting) {
    state = RunState::kAborted;  // the operator's abort, cut short by the daemon's stop
    reason = "aborted; the daemon stopped before the table came to rest";
  } else if (r.state() != RunnerState::kFinished && r.state() != RunnerState::kFaulted) {
    // Stopped (SIGTERM) while running or paused: resumable with `imubench resume RUN`.
    state = RunState::kInterrupted;
    reason = "the daemon stopped during the run";
    const ResumePoint point = store_->resumePoint(run_->id);
    if (point.last_imu_t) {
      reason += "; last stored sample at t = " + std::to_string(*point.last_imu_t) + " s";
    }
  }
  if (auto st = store_->finishRun(run_->id, state, reason); !st.ok) {
    log_.error("store: " + st.message);
  }
  server_->broadcast(RunFinishedEvent{run_->id, runStateName(state), reason});
  if (state == RunState::kFinished && run_->calibration) startFinalCalibration(*run_->calibration);
  if (state == RunState::kFinished && hasTemperaturePoints(r.steps())) {
    startPointCalibrations(run_->id);
  }
  if (state == RunState::kFinished) startFollowUpJudgement(run_->id);
  log_.info("run " + std::to_string(run_->id) + " closed: " + runStateName(state));
  run_.reset();
  notifier_.status("idle");
  // Only a completed run lets the queue go on (next turn of the loop, not from inside the
  // poll that closed the run); after an abort, fault or emergency stop it holds.
  if (state == RunState::kFinished) loop_.post([this] { advanceQueue(); });
}

std::optional<LabStatus> BenchDaemon::labStatus() const {
  if (!lab_) return std::nullopt;
  const lab::MirrorStatus m = lab_->status();
  LabStatus s{
      m.state,     lab::labFaultName(m.fault), m.message, m.backlog, m.shipped, std::nullopt,
      std::nullopt};
  if (m.mirror_samples) {
    s.samples_backlog = m.samples_backlog;
    s.samples_shipped = m.samples_shipped;
  }
  return s;
}

// An alarm (log and topic status) when the mirror goes into a fault or its fault changes, and
// a note when it is back; the fault's text carries no credentials (lab/lab_connection.h).
void BenchDaemon::checkLab() {
  const auto s = labStatus();
  if (!s) return;
  const std::string now = s->state == "fault" ? s->fault + ": " + s->message : "";
  if (now == lab_reported_) return;
  if (!now.empty()) {
    log_.warning("lab mirror ALARM: " + now + " (" + std::to_string(s->backlog) +
                 " item(s) waiting in the outbox; the bench goes on)");
    server_->broadcast(Topic::kStatus, LabAlarmEvent::kAlarm, toJson(LabAlarmEvent{*s}));
  } else {
    log_.info("lab mirror: the lab database is reached again");
    server_->broadcast(Topic::kStatus, LabAlarmEvent::kOk, toJson(LabAlarmEvent{*s}));
  }
  lab_reported_ = now;
}

void BenchDaemon::onStatusTimer() {
  limited_.tick(wallNow());
  checkLab();
  if (!run_) return;
  const PlanRunner& r = *run_->runner;
  const RunStep& s = r.displayedStep();
  const int k = s.index;
  server_->broadcast(ProgressEvent{run_->id, runnerStateName(r.state()), run_->shownProgress(),
                                   r.etaS(), k, s.label});
  std::ostringstream ss;
  ss << run_->plan_name << ": " << runnerStateName(r.state()) << ", step " << k + 1 << "/"
     << r.steps().size() << " (" << s.label << "), " << std::lround(100.0 * run_->progress_shown)
     << " %";
  notifier_.status(ss.str());
}

}  // namespace imubench::daemon
