// imubenchd's core: one epoll loop owning one bench — its table and chamber drivers, the IMU
// reader, the store, the control socket and, while a plan runs, the plan runner and the
// run's writer. Everything happens on the loop's thread:
//
//   IMU socket readable  -> decode -> the run's IMU samples (RunWriter, committed twice a second)
//   table poll timer     -> read table (with or without a run; each read writes the
//                           controller's host-watchdog heartbeat) -> runner.tick -> commands,
//                           events, segments
//   chamber poll timer   -> read chamber (its own, slower period) -> the run's chamber samples
//   runner events        -> store events, control-socket broadcast (topic "run"), syslog
//   status timer         -> topic "status" (progress, ETA, step), sd_notify STATUS, watchdog
//   control socket       -> start/pause/resume/abort/stop/rearm/status/list_plans/
//                           validate_plan/results/export/queue_*; each request first passes
//                           the bench's command rights (daemon/control_rights.h)
//   IMU samples, steps   -> the online engine (daemon/online_engine.h) of a plan naming a
//                           calibration: step statistics on the loop, an `estimate` event
//                           (topic "run") after each step that allows one, computed off it
//   run completed        -> the full calibration off the loop; coefficients, report and
//                           verdict stored as results of the run (event "results")
//   run completed        -> the plan queue's head starts (stored in the database, so the
//                           queue survives a restart; an abort, fault or restart holds it until
//                           queue_resume)
//   plan library reads,  -> a worker thread each (daemon/off_loop.h); the reply is sent from
//   exports                 the loop when the work is done (no file read or write on the loop)
//
// Time: the IMU's sample time is the recording's clock; table and chamber samples and segment
// bounds are stamped with the newest IMU sample time when they are taken. An IMU restart does
// not break it: the decoder re-bases the time axis, the daemon reports the restart (event
// "imu_restart" on topic "run", the run's event log, status "imu_restarts", the log).
//
// Logging: the drivers' retries and faults, the runner's alarms and the IMU's losses go
// through a LogLimiter: a problem repeated on every poll is logged once, then summarised.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/bench_file.h"
#include "daemon/bench_port.h"
#include "daemon/control_server.h"
#include "daemon/event_loop.h"
#include "daemon/log_limiter.h"
#include "daemon/logging.h"
#include "daemon/off_loop.h"
#include "daemon/online_engine.h"
#include "daemon/plan_library.h"
#include "daemon/plan_runner.h"
#include "daemon/sd_notify.h"
#include "daemon/store.h"
#include "drivers/imu_can_reader.h"
#include "lab/shipper.h"

namespace imubench::daemon {

struct LoadedPlan;

struct DaemonOptions {
  std::string socket_path;   // empty: the bench file's control_socket
  std::string storage_path;  // empty: the bench file's storage
  // Table (and chamber) poll period: the table samples of the recording and the runner's
  // reaction time. 20 ms keeps a 300 deg/s axis below 6 deg between two readings.
  double table_poll_s = 0.02;
  double status_period_s = 1.0;  // status events and sd_notify STATUS
  LogLimiterOptions log_limits;  // repeated problems: one line, then a summary per period
  bool IsValid(std::string* why) const;
};

class BenchDaemon {
 public:
  BenchDaemon(BenchConfig bench, DaemonOptions options, const Logger& log);
  ~BenchDaemon();
  BenchDaemon(const BenchDaemon&) = delete;
  BenchDaemon& operator=(const BenchDaemon&) = delete;

  // Opens the store (runs cut off by a crash become "interrupted"), connects the devices,
  // opens the IMU interface and the control socket; then READY=1. An error names the part.
  Status start();
  // Runs the loop until stop() (thread-safe, e.g. from a signal's self-pipe).
  Status run();
  void stop();
  EventLoop& loop() { return loop_; }

 private:
  struct ActiveRun;

  // What a request does with its plan's text; name is what diagnostics call the plan.
  using PlanUse = std::function<Reply(const std::string& name, const std::string& text)>;

  Status startLabMirror(const std::string& db);
  Status startControl(std::string* socket_path);
  // nullopt: the reply follows through the server (a plan read from the plan library).
  std::optional<Reply> handle(const Request& request, ClientId client);
  std::optional<Reply> withPlanText(const Request& request, ClientId client,
                                    const PlanSource& source, const PlanUse& use);
  std::optional<Reply> startPlan(const Request& request, ClientId client);
  Reply startLoaded(const Request& request, const std::string& name, const std::string& text);
  std::unique_ptr<PlanRunner> makeRunner(const LoadedPlan& loaded);
  Reply launch(const LoadedPlan& loaded, const nlohmann::json& id);
  // `resume RUN`: an interrupted run goes on from its last finished step (crash resume).
  Reply resumeInterrupted(const Request& request, std::int64_t run_id);
  // One time axis for a resumed run: the IMU's time must count on from the run's last stored
  // sample, directly or after whole wraps of its time stamp (the decoder and imu_last_t_ are
  // then shifted by them: drivers::resolveTimeWraps). The refusal in words; "" when it does.
  std::string continueImuTimeAxis(const RunInfo& run, const ResumePoint& point);
  // An upper bound of the receive time since run's last stored sample, s (from the wall time
  // of its newest event stored before the interruption, or its start).
  double timeSinceLastStoredSample(const RunInfo& run);
  // The online engine's setup for a plan naming a calibration (nullopt: none); a pipeline
  // whose direct run cannot be found is refused (*why).
  std::optional<OnlineSetup> calibrationSetup(const LoadedPlan& loaded, std::string* why);
  void attachCalibration(ActiveRun& run, OnlineSetup setup);
  void publishEstimate(std::int64_t run, const nlohmann::json& fields);
  // An event of a run: its stored event log and the subscribers of topic "run".
  void announce(std::int64_t run, EventSeverity severity, const std::string& kind,
                const nlohmann::json& fields);
  void startFinalCalibration(const OnlineSetup& setup);
  // A completed thermal run: one direct calibration per temperature point
  // (daemon/thermal_points.h), off the loop, stored as "point_coefficients" results.
  void startPointCalibrations(std::int64_t run_id);
  // A temperature point restarted by the runner: its stored segments are discarded.
  void discardPoint(const RunnerEvent& e);
  Status discardVoidSegments(std::int64_t run_id, const std::vector<RunStep>& steps,
                             const GapRestart& restart, int last_kept, bool point_restart);
  Status discardBeforeResume(std::int64_t run_id, const std::vector<RunStep>& steps,
                             const GapRestart& restart, ResumePoint* point);
  void recordGap(std::int64_t run_id, double from_t, double to_t, const std::string& cause,
                 const std::vector<RunStep>& steps, const GapRestart& restart);
  void storeFinalCalibration(const OnlineSetup& setup, const FinalCalibration& f);
  // The follow-up proposal of a run (daemon/follow_up.h): checked against the bench, stored,
  // announced, and queued with [explain] follow_up = "queue".
  // Returns the stored result's id (nullopt: not stored).
  std::optional<std::int64_t> storeFollowUp(std::int64_t run_id, const FinalCalibration& f);
  // A stored proposal into the queue (queue_accept, the "queue" policy); starts at once when
  // nothing runs and nothing else waits.
  Reply enqueueFollowUp(const nlohmann::json& id, std::int64_t run_id);
  // After a run completed: when it is a follow-up, the joint analysis with its origin.
  void startFollowUpJudgement(std::int64_t run_id);
  Reply enqueue(const Request& request, const std::string& name, const LoadedPlan& loaded);
  Reply startQueued(const nlohmann::json& id);
  void advanceQueue();
  Reply queueReply(const nlohmann::json& id);
  Reply queueChange(const Request& request);
  Reply busyReply(const Request& request) const;
  Reply status() const;
  std::optional<Reply> listPlans(const Request& request, ClientId client);
  std::optional<Reply> validatePlan(const Request& request, ClientId client);
  Reply results(const Request& request);
  std::optional<Reply> exportRun(const Request& request, ClientId client);
  Reply runnerCommand(const Request& request);
  Reply rearm(const Request& request);
  TableStatus tableStatus() const;

  void onImuReadable();
  static constexpr int kImuBatchesPerWake = 8;
  bool readImuBatch();
  void onPoll();
  void stampPendingTable(const drivers::DecodedImuSample& d, bool burst_end);
  // When and how a table reading was read (wall clock, unixNow).
  struct TableReadTiming {
    double at_unix_s = 0.0;        // the reading's instant (the axes' mean read time)
    double round_trip_s = 0.0;     // the axes' longest read round trip (NaN: unknown)
    double poll_duration_s = 0.0;  // the whole poll's (heartbeat, status, every axis)
    double busy_s = 0.0;           // BenchObservation::busy_s of its poll
  };
  void storeTableSample(const io::TableSample& ts, const TableReadTiming& read);
  void onChamberPoll();
  void reportImuProblems();
  // A step of the IMU time longer than this many sample periods is a gap (below calib's
  // refusal threshold, calib::IncrementCheckOptions::max_gap_factor = 5 median steps).
  static constexpr double kGapPeriods = 4.0;
  void checkImuGap(std::size_t i);
  // A gap (IMU time t_a to t_b) in the IMU stream (`what` "IMU data") or the stored table
  // readings ("table data") inside the run.
  void onRecordingGap(double t_a, double t_b, const std::string& what, const std::string& cause);
  void onStatusTimer();
  void publish(const std::vector<RunnerEvent>& events);
  // The lab mirror's state for status, and its alarm on a change into or out of a fault.
  std::optional<LabStatus> labStatus() const;
  void checkLab();
  void beginStep(int step, std::optional<double> t0);
  void closeStep(std::optional<double> t1);
  void closeRun();
  double wallNow() const;

  BenchConfig bench_;
  DaemonOptions options_;
  const Logger& log_;
  LogLimiter limited_;  // log_ for repeated problems
  EventLoop loop_;
  std::unique_ptr<Store> store_;
  // The lab mirror's shipping thread (with a [lab] database), over its own store connection;
  // after store_, so it stops first.
  std::unique_ptr<lab::LabMirror> lab_;
  std::string lab_reported_;  // the fault last alarmed ("" when none)
  std::unique_ptr<drivers::TableDriver> table_;
  std::unique_ptr<drivers::ChamberDriver> chamber_;
  std::unique_ptr<DriverBenchPort> port_;
  std::unique_ptr<drivers::ImuCanReader> imu_;
  std::unique_ptr<ControlServer> server_;
  // After server_ (destroyed first): no late reply is posted once they are gone.
  std::unique_ptr<PlanLibrary> plans_;
  std::unique_ptr<OffLoop> exports_;       // export jobs: a whole run read and written off the loop
  std::unique_ptr<OffLoop> calibrations_;  // online estimates and end-of-plan calibrations
  std::string db_path_;                    // the store's file; exports go next to it
  SystemdNotifier notifier_;
  std::unique_ptr<ActiveRun> run_;
  bool stopping_ = false;  // stop() has begun: no queued plan starts any more
  std::vector<drivers::DecodedImuSample> decoded_;  // per-wake buffers, reused (hot path)
  nav::ImuSamples samples_;
  std::optional<double> imu_last_t_;       // newest IMU sample time (the recording's clock)
  double imu_last_wall_s_ = 0.0;           // when it arrived (wall, monotonic)
  std::optional<double> imu_last_temp_c_;  // its temperature, when the frames carry one
  std::uint64_t imu_lost_reported_ = 0;    // lost-sample count already logged
  std::uint64_t imu_restarts_reported_ = 0;
  std::optional<double> table_answered_s_;  // wallNow() of the last poll the table answered
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

}  // namespace imubench::daemon
