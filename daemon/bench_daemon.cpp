#include "daemon/bench_daemon.h"

#include <fcntl.h>
#include <sys/epoll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <limits>
#include <sstream>

#include "daemon/follow_up.h"
#include "daemon/imu_clock.h"
#include "daemon/plan_check.h"
#include "daemon/thermal_points.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::daemon {

// A plan ready to run on this bench (loadPlan).
struct LoadedPlan {
  plans::Plan plan;
  std::string text;
  calib::Motion motion;
};

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Exports in progress at once: each holds a whole run in memory while it writes it.
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kMaxPendingExports = 2;
// Calibrations in progress at once: a run's estimate (one at a time per run), the previous
// run's end-of-plan calibration, and the next queued run's first estimate.
constexpr std::size_t kMaxPendingCalibrations = 3;

double unixNow() {
  return drivers::unixTimeS();
}

// errno in words: strerror_r (GNU: returns the text, in buf or static), not strerror, which
// may share its buffer with the off-loop threads.
std::string errnoWords(int err) {
  char buf[256];
  return ::strerror_r(err, buf, sizeof buf);
}

std::chrono::nanoseconds seconds(double s) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(s * 1e9));
}

// A plan's text (sent by the client, or read from the plan library) parsed, validated, and
// checked against this bench (table kind, limits). name is what diagnostics call it. nullopt
// with the diagnostics text when refused.
std::optional<LoadedPlan> loadPlan(const std::string& name, const std::string& text,
                                   const BenchConfig& bench, std::string* why) {
  LoadedPlan out;
  out.text = text;
  io::Diagnostics diag(name);
  auto plan = plans::parsePlan(out.text, name, diag);
  if (!plan || !plans::validatePlan(*plan, diag)) {
    *why = diag.str();
    return std::nullopt;
  }
  // Soak and ramp times from the one thermal model with this bench's lags.
  plans::ExpandOptions options;
  if (bench.chamber) {
    options.thermal = {bench.chamber->device.time_constant_s, bench.chamber->imu_time_constant_s};
  }
  auto ex = plans::expand(*plan, options);
  if (!ex.status.ok) {
    *why = name + ": " + ex.status.message;
    return std::nullopt;
  }
  if (const Status fit = checkPlanForBench(*plan, ex.motion, bench); !fit.ok) {
    *why = fit.message;
    return std::nullopt;
  }
  out.plan = std::move(*plan);
  out.motion = std::move(ex.motion);
  return out;
}

// The database and its WAL companions are the daemon's: owner and group read them, nobody
// else. The group is the bench file's read group (else its command group; else the daemon's,
// the operators' imubench group as the systemd unit sets it), so readers can `export --db`. Before
// the store opens it: a missing database is created with that mode, an existing one (and its
// -wal/-shm) is tightened to it. SQLite gives the -wal/-shm it creates the database file's mode;
// after the store is open they are chmod-ed by path only (closing any descriptor of the database
// file would drop the process's SQLite locks on it).
constexpr mode_t kDatabaseMode = 0640;

Status chmodDatabaseFiles(const std::string& db, const std::optional<NamedGroup>& group) {
  for (const std::string& f : {db, db + "-wal", db + "-shm"}) {
    struct stat st {};
    if (::lstat(f.c_str(), &st) != 0 && errno == ENOENT) continue;
    if (Status s = shareWithGroup(f, group, kDatabaseMode); !s.ok) return s;
  }
  return Status::Ok();
}

Status createDatabaseFile(const std::string& db, const std::optional<NamedGroup>& group) {
  const int fd = ::open(db.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, kDatabaseMode);
  if (fd < 0) return Status::Error(db + ": cannot open: " + errnoWords(errno));
  ::close(fd);
  return chmodDatabaseFiles(db, group);
}

// The directory exports go to (exports/ next to the database), created 0750 when missing and
// given to the readers' group. Refused when it is anything but a real directory (e.g. a
// symlink planted there).
Status exportRoot(const std::string& db, const std::optional<NamedGroup>& group,
                  std::string* root) {
  std::error_code ec;
  *root = (fs::absolute(fs::path(db), ec).parent_path() / "exports").string();
  if (ec) return Status::Error(db + ": " + ec.message());
  if (::mkdir(root->c_str(), 0750) != 0 && errno != EEXIST)
    return Status::Error(*root + ": cannot create: " + errnoWords(errno));
  struct stat st {};
  if (::lstat(root->c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    return Status::Error(*root + ": not a directory");
  return shareWithGroup(*root, group, 0750);
}

// Writes run `run` of the store at db to exports/<name> next to it (runs off the loop: its own
// store connection). The reply to the export request with id `id`.
Reply exportToStateDir(const std::string& db, std::int64_t run, const std::string& name,
                       const json& id, const std::optional<NamedGroup>& group) {
  std::string root;
  if (auto st = exportRoot(db, group, &root); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  auto opened = Store::open(db, StoreOptions{});
  if (!opened.status.ok) return errorReply(id, ErrorCode::kInternal, opened.status.message);
  auto rec = opened.value->loadRecording(run);
  if (!rec.status.ok) return errorReply(id, ErrorCode::kNotFound, rec.status.message);
  const std::string dir = root + "/" + name;
  if (::mkdir(dir.c_str(), 0750) != 0) {
    const bool exists = errno == EEXIST;
    return errorReply(id, exists ? ErrorCode::kBadArgument : ErrorCode::kInternal,
                      dir + (exists ? ": exists already; name another export directory (dir)"
                                    : ": cannot create: " + errnoWords(errno)));
  }
  if (auto st = io::writeRecording(dir, rec.value); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  if (auto st = shareDirWithGroup(dir, group); !st.ok)
    return errorReply(id, ErrorCode::kInternal, st.message);
  return okReply(id, toJson(ExportReply{run, dir, rec.value.imu.size()}));
}

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

// The run in progress: its runner, its writer, and the open segment.
struct BenchDaemon::ActiveRun {
  std::int64_t id = 0;
  std::string plan_name;
  std::unique_ptr<PlanRunner> runner;
  std::unique_ptr<RunWriter> writer;
  std::optional<OnlineSetup> calibration;  // the plan names a calibration
  std::unique_ptr<OnlineEngine> engine;    // with it
  std::optional<double> segment_t0;        // IMU time the current step's command went out
  int last_stored_step = -1;               // the step of the newest stored segment
  std::optional<double> last_sample_t;     // the newest stored IMU sample (gaps: onRecordingGap)
  bool imu_restarted = false;              // the decoder saw a restart since the last batch
  // The progress shown (status, progress events): never below what was shown before in this
  // run, though the runner's planned-time figure drops when a step re-runs after a pause.
  double progress_shown = 0.0;
  double shownProgress() {
    progress_shown = std::max(progress_shown, runner->progress());
    return progress_shown;
  }
  // A finished step whose segment waits for the first IMU sample received after the table
  // reading that ended it (after_unix_s, CLOCK_REALTIME like the frames' kernel time stamps).
  struct ClosingStep {
    int step = -1;
    std::string label;
    double after_unix_s = 0.0;
    std::optional<int> next_step;  // started meanwhile: begins where this one ends
    // Its step_finished event, stored only after the segment (the crash-resume checkpoint
    // must never name a step whose segment a kill -9 could still lose).
    RunEvent finished;
  };
  std::optional<ClosingStep> closing;
  // The IMU's rate, low-pass filtered over kStillTauS of sample time: the table is still when
  // it is below kStillRateRadps (far above the Earth rate and a navigation-grade gyro's
  // averaged noise, far below any plan's motion).
  static constexpr double kStillTauS = 0.1;
  static constexpr double kStillRateRadps = 0.1 * kDegToRad;
  Vec3 rate_filtered = Vec3::Zero();
  std::optional<double> rate_last_t;
  void trackStillness(const nav::ImuSample& s) {
    if (rate_last_t && s.t > *rate_last_t) {
      const double dt = s.t - *rate_last_t;
      rate_filtered += (s.dtheta / dt - rate_filtered) * std::min(1.0, dt / kStillTauS);
    }
    rate_last_t = s.t;
  }
  bool imuStill() const { return rate_filtered.norm() < kStillRateRadps; }
  double poll_unix_s = 0.0;  // when the newest table reading was requested
  std::optional<double> last_table_t;
  // How the newest stored table reading was read: a gap in the table readings is judged on it
  // (BenchConfig::table_reading_gap_s). Reset by a gap of the IMU stream, which holds the readings
  // back too and is handled as such.
  std::optional<TableReadTiming> last_table_read;
  // The poll durations of the newest stored readings (at most kPollHistory): their median is
  // the link's cadence. Not the newest poll's own duration: a loop held up inside a poll (the
  // polls are most of its time on a slow link) made that poll long, and it is the gap.
  static constexpr std::size_t kPollHistory = 9;
  std::deque<double> poll_durations_s;
  double typicalPollS(double fallback_s) const {
    if (poll_durations_s.empty()) return fallback_s;
    std::vector<double> v(poll_durations_s.begin(), poll_durations_s.end());
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  }
  void addPollDuration(double s) {
    poll_durations_s.push_back(s);
    if (poll_durations_s.size() > kPollHistory) poll_durations_s.pop_front();
  }
  // A table reading waits for its IMU time. The controller sampled each axis' encoder
  // between the request and the reply that read it (drivers::TableAxisReading::read_unix_s,
  // CLOCK_REALTIME like the frames' kernel receive times); `clock` maps those instants onto
  // the recording's clock (the IMU's sample times), and the axes are brought to their mean
  // instant with their rates. (Stamping the reading with the newest sample before the request
  // lags the table by the round trips and the frames queued meanwhile: the analysis then finds
  // a time delay that is the daemon's own.) The anchors are the last samples of the bursts the
  // IMU sends (frames received within kBurstGapS of each other): a sender that batches its
  // samples sends a burst when its newest sample is due, so that sample, not the burst's
  // first, stands at the receive time; an IMU that sends each sample alone makes every sample
  // an anchor. Until the clock map answers: interpolation between the anchors around the
  // reading's instant; frames without a receive time: the first sample after the reading.
  static constexpr double kBurstGapS = 1e-4;
  struct PendingTable {
    std::array<double, 3> read_unix_s{};        // per axis; 0 when the driver gives none
    std::array<double, 3> rate{};               // rad/s, per axis
    io::TableSample sample;                     // angles set, t to be found
    TableReadTiming read{0.0, kNaN, 0.0, 0.0};  // at_unix_s: the axes' mean read time
  };
  std::optional<PendingTable> pending_table;
  std::optional<double> last_rx_unix_s, last_rx_t;  // newest sample with a receive time
  ImuClockMap clock;
  // The encoder angles as stored: continuous across the controller's +-180 deg wrap (the
  // recording's convention, as the plan writes them), so a three-turn rate run reads 1080 deg.
  // Unwrapped from the previous reading: the table turns far less than half a turn between
  // two polls.
  std::array<std::optional<double>, 3> last_angle;
  double unwrapped(std::size_t axis, double read_rad) {
    std::optional<double>& last = last_angle[axis];
    const double a = last ? *last + std::remainder(read_rad - *last, 2.0 * kPi) : read_rad;
    last = a;
    return a;
  }  // The table reading of obs waiting for its IMU time; polled: the instant of the whole read,
  // for axes the driver gives no read time.
  PendingTable reading(const BenchObservation& obs, double polled, double poll_duration_s) {
    PendingTable p;
    double sum = 0.0;
    std::size_t stamped = 0;
    for (std::size_t a = 0; a < obs.angles.size() && a < 3; ++a) {
      p.sample.angles_deg[a] = unwrapped(a, obs.angles[a]) * kRadToDeg;
      p.rate[a] = a < obs.rates.size() ? obs.rates[a] : 0.0;
      p.read_unix_s[a] = a < obs.angles_unix_s.size() ? obs.angles_unix_s[a] : 0.0;
      if (p.read_unix_s[a] > 0.0) sum += p.read_unix_s[a], ++stamped;
      const double rt = a < obs.angles_round_trip_s.size() ? obs.angles_round_trip_s[a] : 0.0;
      double& longest = p.read.round_trip_s;
      if (rt > 0.0) longest = std::isnan(longest) ? rt : std::max(longest, rt);
    }
    p.read.poll_duration_s = poll_duration_s;
    p.read.busy_s = obs.busy_s;
    p.read.at_unix_s = stamped ? sum / static_cast<double>(stamped) : polled;
    for (double& r : p.read_unix_s) {
      if (!(r > 0.0)) r = p.read.at_unix_s;
    }
    return p;
  }

  std::optional<double> last_chamber_t;
};

bool DaemonOptions::IsValid(std::string* why) const {
  if (!(table_poll_s > 0.0 && table_poll_s <= 1.0)) {
    if (why != nullptr) *why = "table_poll_s must be in (0, 1] s";
    return false;
  }
  if (!(status_period_s > 0.0)) {
    if (why != nullptr) *why = "status_period_s must be positive";
    return false;
  }
  return log_limits.IsValid(why);
}

BenchDaemon::BenchDaemon(BenchConfig bench, DaemonOptions options, const Logger& log)
    : bench_(std::move(bench)),
      options_(std::move(options)),
      log_(log),
      limited_([this](LogLevel level, const std::string& line) { log_.log(level, line); },
               options_.log_limits) {}

BenchDaemon::~BenchDaemon() {
  if (run_) closeRun();
}

double BenchDaemon::wallNow() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

Status BenchDaemon::start() {
  std::string why;
  if (!options_.IsValid(&why)) return Status::Error("daemon options: " + why);
  if (auto st = loop_.open(); !st.ok) return st;

  const std::string db =
      options_.storage_path.empty() ? bench_.storage_path : options_.storage_path;
  const std::optional<NamedGroup> group =
      fileGroup({bench_.control.command_group, bench_.control.read_group, ::geteuid()});
  if (auto st = createDatabaseFile(db, group); !st.ok) return Status::Error("store: " + st.message);
  auto opened = Store::open(db, StoreOptions{});
  if (!opened.status.ok) return Status::Error("store: " + opened.status.message);
  store_ = std::move(opened.value);
  if (auto st = chmodDatabaseFiles(db, group); !st.ok) return Status::Error("store: " + st.message);
  db_path_ = db;
  const auto cut = store_->markInterruptedRuns();
  if (cut.status.ok && cut.value > 0) {
    log_.warning(std::to_string(cut.value) + " run(s) cut off by a crash marked interrupted");
  }
  if (bench_.lab) {
    if (auto st = startLabMirror(db); !st.ok) return st;
  }

  // The drivers report every retry and fault: on a dead link that is every poll.
  const auto sink = [this](const char* topic) {
    return [this, topic](const std::string& m) {
      limited_.report(topic, LogLevel::kWarning, m, wallNow());
    };
  };
  table_ = drivers::makeTableDriver(bench_.table, sink("table"));
  if (auto st = table_->connect(); !st.ok) return Status::Error("table: " + st.message);
  if (bench_.chamber) {
    chamber_ = drivers::makeChamberDriver(bench_.chamber->device, sink("chamber"));
    if (auto st = chamber_->connect(); !st.ok) return Status::Error("chamber: " + st.message);
  }
  port_ = std::make_unique<DriverBenchPort>(*table_, chamber_.get());

  drivers::ImuCanReaderOptions imu_options;
  imu_options.interface = bench_.imu.interface;
  imu_options.decoder.max_clock_ratio = bench_.imu.max_clock_ratio;
  imu_ = std::make_unique<drivers::ImuCanReader>(bench_.imu.layout, imu_options);
  if (auto st = imu_->open(); !st.ok) return Status::Error("IMU: " + st.message);
  if (auto st = loop_.add(imu_->socket().fd(), EPOLLIN, [this](std::uint32_t) { onImuReadable(); });
      !st.ok) {
    return st;
  }

  std::string socket_path;
  if (auto st = startControl(&socket_path); !st.ok) return st;

  EventLoop::TimerId timer{};
  if (auto st = loop_.addTimer(
          seconds(options_.table_poll_s), seconds(options_.table_poll_s), [this] { onPoll(); },
          &timer);
      !st.ok) {
    return st;
  }
  if (bench_.chamber) {
    const auto period = seconds(bench_.chamber->poll_period_s);
    if (auto st = loop_.addTimer(
            period, period, [this] { onChamberPoll(); }, &timer);
        !st.ok) {
      return st;
    }
  }
  if (auto st = loop_.addTimer(
          seconds(options_.status_period_s), seconds(options_.status_period_s),
          [this] { onStatusTimer(); }, &timer);
      !st.ok) {
    return st;
  }
  if (auto wd = notifier_.watchdogInterval()) {
    if (auto st = loop_.addTimer(
            *wd / 2, *wd / 2, [this] { notifier_.watchdog(); }, &timer);
        !st.ok) {
      return st;
    }
  }
  notifier_.ready();
  notifier_.status("idle");
  log_.info("bench '" + bench_.name + "' ready: control socket " + socket_path + ", store " + db +
            ", IMU on " + bench_.imu.interface);
  return Status::Ok();
}

// The [lab] mirror of store db. Never blocks the bench: it connects and ships from its own
// thread, and reports faults through status and the lab_alarm event.
Status BenchDaemon::startLabMirror(const std::string& db) {
  lab::LabEndpoint endpoint;
  endpoint.conninfo = bench_.lab->database;
  endpoint.password_file = bench_.lab->password_file;
  lab::ShipperOptions shipping;
  shipping.mirror_samples = bench_.lab->mirror_samples;
  auto mirror = lab::LabMirror::start(db, endpoint, shipping);
  if (!mirror.ok()) return Status::Error("lab mirror: " + mirror.status.message);
  lab_ = std::move(mirror.value);
  log_.info(std::string("lab mirror: shipping the store's outbox") +
            (shipping.mirror_samples ? " and raw samples" : "") + " to the [lab] database");
  return Status::Ok();
}

// The control socket (with its access policy), the plan library and the export worker.
Status BenchDaemon::startControl(std::string* socket_path) {
  ControlServerOptions server_options;
  server_options.socket_path =
      options_.socket_path.empty() ? bench_.control_socket : options_.socket_path;
  server_options.idle_timeout_s = bench_.control.idle_timeout_s;
  server_options.max_connections_per_uid = bench_.control.max_connections_per_uid;
  server_options.stop_socket_path = bench_.control.stop_socket.empty()
                                        ? server_options.socket_path + ".stop"
                                        : bench_.control.stop_socket;
  if (auto st = systemdListenFd(&server_options.listen_fd); !st.ok) return st;
  server_ = std::make_unique<ControlServer>(
      &loop_, server_options, [this](const Request& r, ClientId c) { return handle(r, c); }, &log_);
  const ControlRights rights{bench_.control.command_group, bench_.control.read_group, ::geteuid()};
  server_->setAccessPolicy([rights](Command c, const PeerCredentials& peer) {
    return checkCommandRights(rights, peer, c);
  });
  // Reserved slots for who may command; root and the daemon's user hold any number.
  server_->setPeerPolicy([rights](const PeerCredentials& peer) {
    const bool trusted = peer.known && (peer.uid == 0 || peer.uid == rights.daemon_uid);
    return ControlServer::PeerClass{mayCommand(rights, peer), !trusted};
  });
  if (rights.command_group) {
    log_.info("control rights: commands need group " + rights.command_group->name +
              (rights.read_group ? ", reading needs group " + rights.read_group->name
                                 : std::string(", reading is open")) +
              "; stop and ping are open to every user who reaches the socket");
  }
  PlanLibraryOptions library;
  std::error_code ec;
  if (!bench_.plan_dir.empty()) library.plan_dir = fs::absolute(bench_.plan_dir, ec).string();
  if (ec) return Status::Error("plan_dir " + bench_.plan_dir + ": " + ec.message());
  plans_ = std::make_unique<PlanLibrary>(&loop_, library);
  exports_ = std::make_unique<OffLoop>(&loop_, kMaxPendingExports);
  calibrations_ = std::make_unique<OffLoop>(&loop_, kMaxPendingCalibrations);
  if (auto st = server_->start(); !st.ok) return Status::Error("control socket: " + st.message);
  *socket_path = server_options.socket_path;
  return Status::Ok();
}

Status BenchDaemon::run() {
  return loop_.run();
}

void BenchDaemon::stop() {
  loop_.post([this] {
    stopping_ = true;
    // Motion stops and the interrupted step re-runs on `resume RUN` after the restart.
    if (run_ && run_->runner->state() == RunnerState::kRunning) {
      run_->runner->pause(wallNow());
      publish(run_->runner->takeEvents());
    }
    if (run_) closeRun();
    notifier_.stopping();
    loop_.stop();
  });
}

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

// ---- control socket ------------------------------------------------------------------------

std::optional<Reply> BenchDaemon::handle(const Request& request, ClientId client) {
  switch (request.command) {
    case Command::kStart:
      return startPlan(request, client);
    case Command::kPause:
    case Command::kResume:
    case Command::kAbort:
    case Command::kStop:
      return runnerCommand(request);
    case Command::kRearm:
      return rearm(request);
    case Command::kStatus:
      return status();
    case Command::kListPlans:
      return listPlans(request, client);
    case Command::kValidatePlan:
      return validatePlan(request, client);
    case Command::kResults:
      return results(request);
    case Command::kExport:
      return exportRun(request, client);
    case Command::kQueueList:
      return queueReply(request.id);
    case Command::kQueueMove:
    case Command::kQueueRemove:
      return queueChange(request);
    case Command::kQueueResume:
      return startQueued(request.id);
    case Command::kQueueAccept:
      return enqueueFollowUp(request.id, std::get<QueueAcceptArgs>(request.args).run);
    case Command::kPing:
    case Command::kSubscribe:
    case Command::kUnsubscribe:
      break;  // the server answers these itself
  }
  return errorReply(request.id, ErrorCode::kInternal, "unhandled command");
}

// The plan's text: inline now, or read from the plan library off the loop and then answered
// through the server (nullopt now). Paths outside the library are refused untouched.
std::optional<Reply> BenchDaemon::withPlanText(const Request& request, ClientId client,
                                               const PlanSource& source, const PlanUse& use) {
  if (source.kind == PlanSource::Kind::kInline)
    return use(source.name.empty() ? "inline plan" : source.name, source.text);
  if (auto why = refuseLibraryPath(source.text, plans_->options().plan_dir))
    return errorReply(request.id, ErrorCode::kBadArgument, "plan.path: " + *why);
  auto done = [this, request, client, path = source.text, use](const PlanFile& file) {
    if (!server_->connected(client)) {
      log_.info("plan " + path + " read for a client that has gone; dropped");
      return;
    }
    Reply r = file.status.ok ? use(path, file.text)
                             : errorReply(request.id, ErrorCode::kBadPlan, file.status.message);
    r.id = request.id;
    server_->sendReply(client, r);
  };
  std::string why;
  if (!plans_->read(source.text, done, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

std::optional<Reply> BenchDaemon::startPlan(const Request& request, ClientId client) {
  if (run_ && !std::get<StartArgs>(request.args).options.queue) return busyReply(request);
  return withPlanText(request, client, std::get<StartArgs>(request.args).plan,
                      [this, request](const std::string& name, const std::string& text) {
                        return startLoaded(request, name, text);
                      });
}

Reply BenchDaemon::busyReply(const Request& request) const {
  return errorReply(request.id, ErrorCode::kBusy,
                    "run " + std::to_string(run_->id) + " (" + run_->plan_name + ") is " +
                        runnerStateName(run_->runner->state()) + "; one plan at a time");
}

Reply BenchDaemon::startLoaded(const Request& request, const std::string& name,
                               const std::string& text) {
  const auto& args = std::get<StartArgs>(request.args);
  if (run_ && !args.options.queue) return busyReply(request);  // another start won the race
  std::string why;
  auto loaded = loadPlan(name, text, bench_, &why);
  if (!loaded) return errorReply(request.id, ErrorCode::kBadPlan, why);
  if (args.options.dry_run) {
    const PlanSummary summary{loaded->plan.name,
                              static_cast<std::int64_t>(runSteps(loaded->motion).size()),
                              loaded->motion.duration};
    return okReply(request.id, toJson(DryRunReply{true, summary}));
  }
  if (args.options.queue) {
    const auto waiting = store_->queueList();
    if (!waiting.status.ok)
      return errorReply(request.id, ErrorCode::kInternal, waiting.status.message);
    if (run_ || !waiting.value.empty()) return enqueue(request, name, *loaded);
  }
  return launch(*loaded, request.id);
}

// The plan's runner with the bench's safety settings.
std::unique_ptr<PlanRunner> BenchDaemon::makeRunner(const LoadedPlan& loaded) {
  RunnerOptions ro;
  ro.comm_timeout_s = bench_.safety.comm_timeout_s;
  ro.imu_timeout_s = bench_.safety.imu_timeout_s;
  if (bench_.chamber) {
    ro.chamber_safe_setpoint_c = bench_.chamber->safe_setpoint_c;
    ro.chamber_over_temperature_c = bench_.chamber->over_temperature_c;
  }
  return std::make_unique<PlanRunner>(runSteps(loaded.motion), ro, *port_);
}

// Starts a validated plan now (no run going): the runner, then the run's record. The reply to
// the request with id `id`.
Reply BenchDaemon::launch(const LoadedPlan& loaded, const json& id) {
  std::string why;
  std::optional<OnlineSetup> calibration = calibrationSetup(loaded, &why);
  if (!why.empty()) return errorReply(id, ErrorCode::kBadState, why);
  auto runner = makeRunner(loaded);
  // Started before the run is recorded: a bench that cannot move (controller unreachable,
  // emergency stop not cleared) gets no run record, nothing was attempted. The runner's
  // first events wait in its queue until the run has an id.
  if (const Status started = runner->start(wallNow()); !started.ok) {
    return errorReply(id, ErrorCode::kBadState, started.message);
  }
  RunStart start;
  start.plan_name = loaded.plan.name;
  start.plan_toml = loaded.text;
  start.bench_name = bench_.name;
  start.imu_serial = bench_.imu.serial;
  start.imu_rate_hz = 1.0 / bench_.imu.layout.sample_period_s;
  start.latitude_deg = bench_.site.latitude_rad * kRadToDeg;
  start.height_m = bench_.site.height_m;
  start.gravity_mps2 = bench_.site.gravity_mps2;
  start.table_kind = bench_.table.kind;
  if (start.table_kind == calib::TableKind::kTwoAxis) {
    start.outer_axis_heading_deg = bench_.outer_axis_heading_rad * kRadToDeg;
  }
  auto begun = store_->beginRun(start);
  if (!begun.status.ok) return errorReply(id, ErrorCode::kInternal, begun.status.message);
  auto run = std::make_unique<ActiveRun>();
  run->id = begun.value;
  run->plan_name = loaded.plan.name;
  run->runner = std::move(runner);
  run->writer = std::make_unique<RunWriter>(*store_, begun.value);
  if (calibration) attachCalibration(*run, std::move(*calibration));
  run_ = std::move(run);
  publish(run_->runner->takeEvents());
  log_.info("run " + std::to_string(run_->id) + " started: plan '" + run_->plan_name + "'");
  const PlanSummary summary{run_->plan_name,
                            static_cast<std::int64_t>(run_->runner->steps().size()),
                            run_->runner->plannedTotalS()};
  return okReply(id, toJson(StartReply{run_->id, summary, std::nullopt}));
}

// The newest wall time the run's stored events vouch for as no later than its last stored
// sample (+ the writer's unflushed tail): the run's start, every event but the "interrupted"
// one a restarted daemon adds at start-up. Unknown events: the run's start alone.
double BenchDaemon::timeSinceLastStoredSample(const RunInfo& run) {
  double last_wall = run.started_unix_s;
  const EventListResult events = store_->events(run.id);
  if (events.status.ok) {
    for (const RunEvent& e : events.value) {
      if (e.kind != "interrupted") last_wall = std::max(last_wall, e.wall_unix_s);
    }
  } else {
    log_.warning("run " + std::to_string(run.id) + ": " + events.status.message);
  }
  // A kill -9 loses the rows still buffered: the last stored sample may precede the newest
  // event by up to the writer's unflushed span (of sample time; the IMU's clock runs no
  // slower than the receive clock).
  return unixNow() - last_wall + store_->options().max_unflushed_s;
}

std::string BenchDaemon::continueImuTimeAxis(const RunInfo& run, const ResumePoint& point) {
  if (!imu_last_t_) return "the IMU is silent; resume when it streams";
  if (!point.last_imu_t || *imu_last_t_ > *point.last_imu_t) return "";
  const drivers::ImuDecoder& decoder = imu_->decoder();
  const double elapsed = timeSinceLastStoredSample(run);
  const drivers::TimeWrapResolution wraps = drivers::resolveTimeWraps(
      *imu_last_t_, *point.last_imu_t, decoder.timeWrapPeriod(), elapsed, decoder.options());
  if (!wraps.wraps) {
    return wraps.why + "; start a new run";
  }
  const double shift = static_cast<double>(*wraps.wraps) * *decoder.timeWrapPeriod();
  imu_->shiftTimeWraps(*wraps.wraps);
  imu_last_t_ = *imu_last_t_ + shift;
  log_.info("run " + std::to_string(run.id) + ": the IMU time stamp wrapped " +
            std::to_string(*wraps.wraps) + " time(s) since the run's last sample; its time " +
            "axis goes on " + std::to_string(shift) + " s later");
  return "";
}

// Crash resume: run `run_id` (interrupted by a crash, a power loss or a stop, or aborted or
// faulted) goes on from the step after its last finished one (the start of its temperature
// point in a thermal plan: plan_runner.h resumeStep), on the same bench and IMU and one time axis;
// the rows already stored stay, the new ones append to the same run.
Reply BenchDaemon::resumeInterrupted(const Request& request, std::int64_t run_id) {
  const json& id = request.id;
  const std::string which = "run " + std::to_string(run_id);
  if (run_) return busyReply(request);
  const RunInfoResult info = store_->runInfo(run_id);
  if (!info.status.ok) return errorReply(id, ErrorCode::kNotFound, info.status.message);
  const RunInfo& run = info.value;
  if (!runResumable(run.state)) {
    return errorReply(id, ErrorCode::kBadState,
                      which + " is " + runStateName(run.state) +
                          "; only an interrupted, aborted or faulted run can be resumed (a "
                          "paused one: resume)");
  }
  if (run.start.bench_name != bench_.name || run.start.imu_serial != bench_.imu.serial) {
    return errorReply(id, ErrorCode::kBadState,
                      which + " ran on bench '" + run.start.bench_name + "' with IMU '" +
                          run.start.imu_serial + "'; this is bench '" + bench_.name +
                          "' with IMU '" + bench_.imu.serial + "'");
  }
  std::string why;
  const auto loaded = loadPlan(run.start.plan_name, run.start.plan_toml, bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, which + ": " + why);
  ResumePoint point = store_->resumePoint(run_id);
  if (!point.status.ok) return errorReply(id, ErrorCode::kInternal, point.status.message);
  // One time axis: the IMU must still count on from where the run's samples end.
  if (const std::string axis = continueImuTimeAxis(run, point); !axis.empty()) {
    return errorReply(id, ErrorCode::kBadState, which + ": " + axis);
  }
  why.clear();
  std::optional<OnlineSetup> calibration = calibrationSetup(*loaded, &why);
  if (!why.empty()) return errorReply(id, ErrorCode::kBadState, which + ": " + why);
  auto runner = makeRunner(*loaded);
  // An interrupted temperature point restarts at its chamber step; elsewhere no rotation may
  // touch the gap the interruption left (plan_runner.h resumeAfterGap): the void segments go.
  const GapRestart restart = resumeAfterGap(runner->steps(), point.last_finished_step);
  const int next = restart.step;
  const bool done = next >= static_cast<int>(runner->steps().size());
  if (!done && restart.first_void <= point.last_finished_step) {
    if (auto st = discardBeforeResume(run_id, runner->steps(), restart, &point); !st.ok)
      return errorReply(id, ErrorCode::kInternal, st.message);
  }
  if (!done) {
    if (const Status started = runner->startAt(wallNow(), next); !started.ok) {
      return errorReply(id, ErrorCode::kBadState, which + ": " + started.message);
    }
  }
  if (auto st = store_->resumeRun(run_id); !st.ok) {
    return errorReply(id, ErrorCode::kInternal, st.message);
  }
  if (!done && point.last_imu_t) {
    recordGap(run_id, *point.last_imu_t, *imu_last_t_, "the daemon was down (resume)",
              runner->steps(), restart);
  }
  if (done) {  // every step had finished; only the closing was cut off
    if (auto st = store_->finishRun(run_id, RunState::kFinished, "completed"); !st.ok)
      return errorReply(id, ErrorCode::kInternal, st.message);
    if (calibration) {
      calibration->run_id = run_id;
      startFinalCalibration(*calibration);
    }
    if (hasTemperaturePoints(runner->steps())) startPointCalibrations(run_id);
    return okReply(id, {{"run", run_id}, {"state", "finished"}, {"from_step", next}});
  }
  auto active = std::make_unique<ActiveRun>();
  active->id = run_id;
  active->plan_name = run.start.plan_name;
  active->runner = std::move(runner);
  active->writer = std::make_unique<RunWriter>(*store_, run_id, point);
  active->last_table_t = point.last_table_t;
  active->last_chamber_t = point.last_chamber_t;
  active->last_stored_step = restart.first_void - 1;
  // The plan's calibration goes on too: the final one reads every stored sample (before and
  // after the interruption); the online estimates start again from the resumed step.
  if (calibration) attachCalibration(*active, std::move(*calibration));
  run_ = std::move(active);
  server_->broadcast(Topic::kRun, "resumed", {{"run", run_id}, {"from_step", next}});
  publish(run_->runner->takeEvents());
  log_.info(which + " resumed at step " + std::to_string(next + 1) + "/" +
            std::to_string(run_->runner->steps().size()) + " (plan '" + run_->plan_name + "')");
  return okReply(id, {{"run", run_id},
                      {"state", runnerStateName(run_->runner->state())},
                      {"from_step", next},
                      {"steps", run_->runner->steps().size()}});
}

// The stored segments a gap made void (plan_runner.h GapRestart) are discarded: a temperature
// point's from its chamber step on; a rotation's that lost its hold after only while it is
// still the newest stored (a second resume finds it gone already).
Status BenchDaemon::discardVoidSegments(std::int64_t run_id, const std::vector<RunStep>& steps,
                                        const GapRestart& restart, int last_kept,
                                        bool point_restart) {
  const auto& first = steps[static_cast<std::size_t>(restart.first_void)];
  if (point_restart) {
    return store_->discardSegmentsFrom(run_id, first.label).status;
  }
  std::vector<std::string> labels;
  for (int k = restart.first_void; k <= last_kept; ++k)
    labels.push_back(steps[static_cast<std::size_t>(k)].label);
  return store_->discardTrailingSegments(run_id, labels).status;
}

// A resume's void segments go (resumeAfterGap); point is read again after.
Status BenchDaemon::discardBeforeResume(std::int64_t run_id, const std::vector<RunStep>& steps,
                                        const GapRestart& restart, ResumePoint* point) {
  const int last = point->last_finished_step;
  const bool point_restart = resumeStep(steps, last) <= last;
  if (auto st = discardVoidSegments(run_id, steps, restart, last, point_restart); !st.ok) return st;
  *point = store_->resumePoint(run_id);
  return point->status;
}

// A gap in the run's recording (IMU time from_t to to_t): event "recording_gap" in the run's
// event log, to subscribers and the log, naming where the run goes on and what runs again.
void BenchDaemon::recordGap(std::int64_t run_id, double from_t, double to_t,
                            const std::string& cause, const std::vector<RunStep>& steps,
                            const GapRestart& restart) {
  json fields = {{"run", run_id}, {"from_t", from_t}, {"to_t", to_t}, {"cause", cause}};
  const int n = static_cast<int>(steps.size());
  if (restart.step < n) {
    fields["step"] = restart.step;
    fields["label"] = steps[static_cast<std::size_t>(restart.step)].label;
  }
  // Steps that run again although their segments stored before the gap stay (gapRestart).
  fields["rerun_kept"] = json::array();
  for (int k = restart.step; k < restart.first_void && k < n; ++k)
    fields["rerun_kept"].push_back(steps[static_cast<std::size_t>(k)].label);
  std::ostringstream msg;
  msg << "recording gap from t = " << from_t << " s to t = " << to_t << " s (" << cause
      << "): no segment spans it";
  if (restart.step < n)
    msg << "; the run goes on at step '" << fields["label"].get<std::string>() << "'";
  fields["message"] = msg.str();
  RunEvent stored;
  stored.run_id = run_id;
  stored.wall_unix_s = unixNow();
  stored.severity = EventSeverity::kWarning;
  stored.kind = "recording_gap";
  stored.json = fields.dump();
  if (auto st = store_->addEvent(stored); !st.ok) log_.error("store: " + st.message);
  server_->broadcast(Topic::kRun, "recording_gap", fields);
  log_.warning("run " + std::to_string(run_id) + ": " + msg.str());
}

// ---- calibration (daemon/online_engine.h) ---------------------------------------------------

// The run feeds the plan's calibration: the online engine during the run, the final
// calibration when it completes.
void BenchDaemon::attachCalibration(ActiveRun& run, OnlineSetup setup) {
  setup.run_id = run.id;
  run.calibration = setup;
  run.engine = std::make_unique<OnlineEngine>(
      std::move(setup), calibrations_.get(),
      [this, run_id = run.id](const json& fields) { publishEstimate(run_id, fields); });
}

std::optional<OnlineSetup> BenchDaemon::calibrationSetup(const LoadedPlan& loaded,
                                                         std::string* why) {
  const plans::Plan& plan = loaded.plan;
  if (plan.calibration == plans::CalibrationMethod::kNone) return std::nullopt;
  OnlineSetup setup;
  setup.method = plan.calibration;
  setup.db_path = db_path_;
  setup.acceptance = bench_.acceptance;
  setup.known_table_errors = bench_.table_errors;
  if (bench_.explain.follow_up != FollowUpPolicy::kOff) {
    calib::ProposeOptions propose;  // the search's defaults within this bench's table limits
    propose.limits.max_rate_rad_s = bench_.table.limits.max_rate;
    propose.limits.max_accel_rad_s2 = bench_.table.limits.max_accel;
    setup.follow_up = propose;
  }
  io::Recording& meta = setup.meta;
  meta.latitude_deg = bench_.site.latitude_rad * kRadToDeg;
  meta.height_m = bench_.site.height_m;
  meta.gravity_mps2 = bench_.site.gravity_mps2;
  meta.imu_serial = bench_.imu.serial;
  meta.imu_rate_hz = 1.0 / bench_.imu.layout.sample_period_s;
  meta.table_kind = bench_.table.kind;
  if (meta.table_kind == calib::TableKind::kTwoAxis)
    meta.outer_axis_heading_deg = bench_.outer_axis_heading_rad * kRadToDeg;
  meta.segments_from_file = true;
  if (plan.calibration != plans::CalibrationMethod::kPipeline) return setup;
  // The pipeline's direct part: the newest completed run of direct_plan for this IMU.
  const auto runs = store_->listRuns();
  if (!runs.status.ok) {
    *why = "store: " + runs.status.message;
    return std::nullopt;
  }
  for (auto it = runs.value.rbegin(); it != runs.value.rend(); ++it) {
    if (it->state == RunState::kFinished && it->exit_reason == runExitName(RunExit::kCompleted) &&
        it->start.plan_name == plan.direct_plan && it->start.imu_serial == bench_.imu.serial) {
      setup.direct_run = it->id;
      return setup;
    }
  }
  *why = "plan '" + plan.name + "' (calibration = \"pipeline\") needs a completed run of plan '" +
         plan.direct_plan + "' for IMU serial '" + bench_.imu.serial +
         "' on this bench: run that plan first";
  return std::nullopt;
}

// An estimate of the online engine: the run's event log, subscribers (topic "run"), the log.
void BenchDaemon::publishEstimate(std::int64_t run, const json& fields) {
  announce(run, EventSeverity::kInfo, "estimate", fields);
  log_.info("run " + std::to_string(run) + ": estimate after " +
            fields.value("summary", std::string("a step")));
}

void BenchDaemon::announce(std::int64_t run, EventSeverity severity, const std::string& kind,
                           const json& fields) {
  const RunEvent stored{run, unixNow(), severity, kind, fields.dump()};
  if (auto st = store_->addEvent(stored); !st.ok) log_.error("store: " + st.message);
  server_->broadcast(Topic::kRun, kind, fields);
}

// The full calibration of a completed run, off the loop; the results are stored on the loop.
void BenchDaemon::startFinalCalibration(const OnlineSetup& setup) {
  auto job = [this, setup]() -> std::function<void()> {
    FinalCalibration f = finalCalibration(setup);
    return [this, setup, f = std::move(f)] { storeFinalCalibration(setup, f); };
  };
  auto failed = [this, run = setup.run_id](const std::string& what) {
    log_.error("run " + std::to_string(run) + ": calibration failed: " + what);
    server_->broadcast(Topic::kRun, "results", {{"run", run}, {"ok", false}, {"error", what}});
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

void BenchDaemon::startPointCalibrations(std::int64_t run_id) {
  auto job = [this, run_id, db = db_path_, known = bench_.table_errors]() -> std::function<void()> {
    std::string error, serial;
    std::vector<PointCalibration> points;
    auto opened = Store::open(db, StoreOptions{});
    if (opened.status.ok) {
      const auto rec = opened.value->loadRecording(run_id);
      if (rec.status.ok) {
        serial = rec.value.imu_serial;
        points = calibrateTemperaturePoints(rec.value, known);
      } else {
        error = rec.status.message;
      }
    } else {
      error = opened.status.message;
    }
    return [this, run_id, error, serial, points = std::move(points)] {
      const std::string who = "run " + std::to_string(run_id);
      if (!error.empty()) {
        log_.error(who + ": no temperature point results: " + error);
        return;
      }
      int ok = 0;
      for (const PointCalibration& p : points) {
        const auto r = store_->storeResult(run_id, serial, p.temperature_c, "point_coefficients",
                                           pointJson(p).dump());
        if (!r.status.ok) log_.error("store: " + r.status.message);
        ok += p.status.ok ? 1 : 0;
      }
      log_.info(who + ": " + std::to_string(ok) + " of " + std::to_string(points.size()) +
                " temperature points calibrated (IMU " + serial + ")");
      server_->broadcast(
          Topic::kRun, "point_results",
          {{"run", run_id}, {"points", static_cast<int>(points.size())}, {"calibrated", ok}});
    };
  };
  auto failed = [this, run_id](const std::string& what) {
    log_.error("run " + std::to_string(run_id) + ": temperature point calibration failed: " + what);
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

void BenchDaemon::storeFinalCalibration(const OnlineSetup& setup, const FinalCalibration& f) {
  const std::string who = "run " + std::to_string(setup.run_id);
  if (!f.status.ok) {
    log_.error(who + ": no calibration results: " + f.status.message);
    server_->broadcast(Topic::kRun, "results",
                       {{"run", setup.run_id}, {"ok", false}, {"error", f.status.message}});
    return;
  }
  json stored = json::object();
  auto keep = [&](const char* kind, const json& j) {
    const auto r = store_->storeResult(setup.run_id, f.imu_serial, f.temperature_c, kind, j.dump());
    if (!r.status.ok) log_.error("store: " + r.status.message);
    if (r.status.ok) stored[kind] = r.value;
  };
  if (f.calibrated) keep("coefficients", f.coefficients);
  keep("report", f.report);
  keep("verdict", f.verdict);
  if (f.explain) keep("explain", *f.explain);
  if (f.follow_up) {
    if (const auto id = storeFollowUp(setup.run_id, f)) stored[kFollowUpKind] = *id;
  }
  if (f.explain) {
    log_.info(who + ": " + f.explain_summary);
  } else {
    log_.warning(who + ": " + f.explain_error);
  }
  const json pass = f.verdict.value("pass", json());
  const std::string verdict = pass.is_boolean() ? (pass.get<bool>() ? "PASS" : "FAIL")
                              : !f.verdict.value("usable", true) ? "none (the fit is unusable)"
                                                                 : "none";
  log_.info(who + ": calibration " + (f.calibrated ? "done" : "FAILED") + ", verdict " + verdict +
            " (IMU " + f.imu_serial + ")");
  server_->broadcast(Topic::kRun, "results",
                     {{"run", setup.run_id},
                      {"ok", true},
                      {"calibrated", f.calibrated},
                      {"pass", pass},
                      {"usable", f.verdict.value("usable", true)},
                      {"imu_serial", f.imu_serial},
                      {"temperature_c", f.temperature_c},
                      {"explain", f.explain ? f.explain_summary : f.explain_error},
                      {"results", stored}});
}

// ---- the follow-up experiment (daemon/follow_up.h) -------------------------------------------

std::optional<std::int64_t> BenchDaemon::storeFollowUp(std::int64_t run_id,
                                                       const FinalCalibration& f) {
  json proposal = *f.follow_up;
  std::string why;
  if (proposal.value("status", "") == "proposed" &&
      !loadPlan(proposal["plan"].value("name", ""), proposal["plan"].value("toml", ""), bench_,
                &why)) {
    // Never stored as runnable what this bench would refuse (its limits, its table).
    proposal["status"] = "refused";
    proposal["reason"] = "the designed plan is refused by this bench: " + why;
    proposal.erase("plan");
  }
  proposal["policy"] = followUpPolicyName(bench_.explain.follow_up);
  const auto r =
      store_->storeResult(run_id, f.imu_serial, f.temperature_c, kFollowUpKind, proposal.dump());
  if (!r.status.ok) {
    log_.error("store: " + r.status.message);
    return std::nullopt;
  }
  const std::string summary = followUpSummary(proposal);
  json fields = {{"run", run_id}, {"status", proposal["status"]}, {"summary", summary}};
  if (proposal.contains("plan")) {
    fields["plan"] = proposal["plan"]["name"];
    fields["duration_s"] = proposal["plan"]["duration_s"];
  }
  fields["groups"] = json::array();
  for (const json& g : proposal["groups"]) {
    fields["groups"].push_back(
        {{"effects", g["effects"]}, {"resolved", g["resolved"]}, {"why", g["why"]}});
  }
  announce(run_id, EventSeverity::kInfo, "follow_up", fields);
  log_.info("run " + std::to_string(run_id) + ": " + summary);
  if (bench_.explain.follow_up == FollowUpPolicy::kQueue && proposal["status"] == "proposed") {
    const Reply q = enqueueFollowUp(nullptr, run_id);
    if (!q.ok)
      log_.warning("run " + std::to_string(run_id) + ": follow-up not queued: " + q.error.message);
  }
  return r.value;
}

Reply BenchDaemon::enqueueFollowUp(const json& id, std::int64_t run_id) {
  ResultFilter filter;
  filter.run_id = run_id;
  const ResultListResult results = store_->results(filter);
  if (!results.status.ok) return errorReply(id, ErrorCode::kInternal, results.status.message);
  const std::string who = "run " + std::to_string(run_id);
  std::optional<json> proposal;
  for (const StoredResult& r : results.value) {
    if (r.kind == kFollowUpKind) proposal = json::parse(r.json, nullptr, false);
  }
  if (!proposal || proposal->is_discarded())
    return errorReply(id, ErrorCode::kNotFound, who + " has no stored follow-up proposal");
  if (proposal->value("status", "") != "proposed") {
    return errorReply(id, ErrorCode::kBadState,
                      who + "'s follow-up holds no plan: " + proposal->value("reason", "?"));
  }
  const std::string name = (*proposal)["plan"].value("name", "");
  std::string why;
  const auto loaded = loadPlan(name, (*proposal)["plan"].value("toml", ""), bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, who + "'s follow-up: " + why);
  QueueEntry entry;
  entry.plan_name = loaded->plan.name;
  entry.source = name;
  entry.plan_toml = loaded->text;
  entry.label = "follow-up of run " + std::to_string(run_id);
  const QueueAddResult added = store_->queueAdd(entry);
  if (!added.status.ok) return errorReply(id, ErrorCode::kInternal, added.status.message);
  const QueuedEvent queued{added.value.entry_id, added.value.position, entry.plan_name};
  log_.info("follow-up of " + who + " queued: entry " + std::to_string(added.value.entry_id) +
            ", position " + std::to_string(added.value.position));
  server_->broadcast(queued);
  // Alone in the queue with the bench idle: it starts now (a held queue stays held).
  if (!run_ && added.value.position == 1) loop_.post([this] { advanceQueue(); });
  return okReply(id, toJson(QueuedReply{queued}));
}

void BenchDaemon::startFollowUpJudgement(std::int64_t run_id) {
  auto job = [this, run_id, db = db_path_, known = bench_.table_errors]() -> std::function<void()> {
    std::optional<FollowUpJudged> j = judgeFollowUp(db, run_id, known);
    return [this, run_id, j = std::move(j)] {
      if (!j) return;  // not a follow-up
      const auto r = store_->storeResult(run_id, j->imu_serial, j->temperature_c,
                                         kFollowUpJointKind, j->joint.dump());
      if (!r.status.ok) log_.error("store: " + r.status.message);
      const bool ok = j->joint.value("ok", false);
      json fields = {{"run", run_id},
                     {"origin_run", j->joint["origin_run"]},
                     {"ok", ok},
                     {"summary", ok ? j->joint.value("summary", "") : j->joint.value("error", "")},
                     {"groups", json::array()}};
      for (const json& g : j->joint["groups"])
        fields["groups"].push_back({{"effects", g["effects"]}, {"verdict", g["verdict"]}});
      announce(run_id, ok ? EventSeverity::kInfo : EventSeverity::kWarning, "follow_up_verdict",
               fields);
      log_.info("run " + std::to_string(run_id) + " (follow-up of run " +
                fields["origin_run"].dump() + "): " + fields["summary"].get<std::string>());
    };
  };
  auto failed = [this, run_id](const std::string& what) {
    log_.error("run " + std::to_string(run_id) + ": follow-up judgement failed: " + what);
  };
  std::string why;
  if (!calibrations_->run(job, failed, &why)) failed(why);
}

// ---- the plan queue (stored: it survives a restart) -----------------------------------------

// A validated plan appended to the queue; it starts when the runs before it have completed.
Reply BenchDaemon::enqueue(const Request& request, const std::string& name,
                           const LoadedPlan& loaded) {
  QueueEntry entry;
  entry.plan_name = loaded.plan.name;
  entry.source = name;
  entry.plan_toml = loaded.text;
  entry.label = std::get<StartArgs>(request.args).options.label;
  const QueueAddResult added = store_->queueAdd(entry);
  if (!added.status.ok) return errorReply(request.id, ErrorCode::kInternal, added.status.message);
  const QueuedEvent queued{added.value.entry_id, added.value.position, entry.plan_name};
  log_.info("plan '" + entry.plan_name + "' queued: entry " + std::to_string(added.value.entry_id) +
            ", position " + std::to_string(added.value.position));
  server_->broadcast(queued);
  return okReply(request.id, toJson(QueuedReply{queued}));
}

// The queue's head started now (no run going). It leaves the queue only once it has started;
// a plan the bench refuses now stays queued (the reply says why).
Reply BenchDaemon::startQueued(const json& id) {
  if (run_) {
    return errorReply(id, ErrorCode::kBadState,
                      "run " + std::to_string(run_->id) +
                          " is going; the queue goes on by itself when it completes");
  }
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(id, ErrorCode::kInternal, list.status.message);
  if (list.value.empty()) return errorReply(id, ErrorCode::kNotFound, "the queue is empty");
  const QueueEntry& head = list.value.front();
  const std::string which =
      "queue entry " + std::to_string(head.id) + " (plan '" + head.plan_name + "')";
  std::string why;
  const auto loaded = loadPlan(head.source, head.plan_toml, bench_, &why);
  if (!loaded) return errorReply(id, ErrorCode::kBadPlan, which + ": " + why);
  Reply r = launch(*loaded, id);
  if (!r.ok) {
    r.error.message = which + ": " + r.error.message;
    return r;
  }
  if (auto st = store_->queueRemove(head.id); !st.ok) log_.error("store: " + st.message);
  r.result["entry"] = head.id;  // StartReply::entry
  server_->broadcast(QueueStartedEvent{head.id, run_->id, run_->plan_name});
  log_.info(which + " started as run " + std::to_string(run_->id));
  return r;
}

// After a run completed: the next queued plan, if any. One that cannot start holds the queue.
void BenchDaemon::advanceQueue() {
  if (stopping_ || run_) return;
  const Reply r = startQueued(nullptr);
  if (r.ok || r.error.code == ErrorCode::kNotFound) return;
  log_.warning("queue held: " + r.error.message);
  server_->broadcast(QueueHeldEvent{r.error.message});
}

Reply BenchDaemon::queueReply(const json& id) {
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(id, ErrorCode::kInternal, list.status.message);
  QueueReply reply;
  for (std::size_t i = 0; i < list.value.size(); ++i) {
    const QueueEntry& e = list.value[i];
    reply.queue.push_back(
        {e.id, static_cast<std::int64_t>(i + 1), e.plan_name, e.source, e.label, e.added_unix_s});
  }
  return okReply(id, toJson(reply));
}

// queue_move and queue_remove; the reply is the queue as it is now.
Reply BenchDaemon::queueChange(const Request& request) {
  const bool move = request.command == Command::kQueueMove;
  const std::int64_t entry = move ? std::get<QueueMoveArgs>(request.args).entry
                                  : std::get<QueueRemoveArgs>(request.args).entry;
  const QueueListResult list = store_->queueList();
  if (!list.status.ok) return errorReply(request.id, ErrorCode::kInternal, list.status.message);
  const std::string which = "queue entry " + std::to_string(entry);
  if (std::none_of(list.value.begin(), list.value.end(),
                   [entry](const QueueEntry& e) { return e.id == entry; }))
    return errorReply(request.id, ErrorCode::kNotFound, which + " is not queued");
  Status st;
  if (move) {
    const int position = std::get<QueueMoveArgs>(request.args).position;
    if (static_cast<std::size_t>(position) > list.value.size()) {
      return errorReply(request.id, ErrorCode::kBadArgument,
                        "position: " + std::to_string(position) + " is beyond the queue's " +
                            std::to_string(list.value.size()) + " entries");
    }
    st = store_->queueMove(entry, position);
  } else {
    st = store_->queueRemove(entry);
  }
  if (!st.ok) return errorReply(request.id, ErrorCode::kInternal, st.message);
  log_.info(which + (move ? " moved" : " removed"));
  return queueReply(request.id);
}

Reply BenchDaemon::runnerCommand(const Request& request) {
  const double now = wallNow();
  if (request.command == Command::kStop) {
    // Emergency stop works in every state, with or without a run.
    if (run_) {
      run_->runner->emergencyStop(now, "operator (control socket)");
      publish(run_->runner->takeEvents());
      closeRun();
    } else {
      const Status st = port_->emergencyStop();
      log_.warning("emergency stop (no run)" + (st.ok ? std::string() : ": " + st.message));
    }
    return okReply(request.id, toJson(StopReply{true}));
  }
  if (request.command == Command::kResume) {
    const std::optional<std::int64_t> which = std::get<ResumeArgs>(request.args).run;
    if (which && (!run_ || run_->id != *which)) return resumeInterrupted(request, *which);
  }
  if (!run_) return errorReply(request.id, ErrorCode::kBadState, "no run in progress");
  Status r;
  if (request.command == Command::kPause) r = run_->runner->pause(now);
  if (request.command == Command::kResume) r = run_->runner->resume(now);
  if (request.command == Command::kAbort) r = run_->runner->abort(now);
  publish(run_->runner->takeEvents());
  if (!r.ok) return errorReply(request.id, ErrorCode::kBadState, r.message);
  return okReply(request.id,
                 toJson(RunCommandReply{run_->id, runnerStateName(run_->runner->state())}));
}

// After a controller restart (interlock open, modes lost) the run stays paused until the
// operator re-arms: the same preparation as a start (connect, interlock closed, refused on an
// emergency stop or trip, which are cleared at the controller). Never while the table moves.
Reply BenchDaemon::rearm(const Request& request) {
  if (run_ && run_->runner->state() != RunnerState::kPaused) {
    return errorReply(request.id, ErrorCode::kBadState,
                      std::string("re-arm only with no run or a paused one; the run is ") +
                          runnerStateName(run_->runner->state()) + " (pause it first)");
  }
  const Status st = port_->prepare();
  const std::string who = run_ ? "run " + std::to_string(run_->id) + ": " : std::string();
  if (!st.ok) {
    log_.warning(who + "re-arm refused: " + st.message);
    return errorReply(request.id, ErrorCode::kBadState, "re-arm refused: " + st.message);
  }
  table_answered_s_ = wallNow();  // prepare() read the table
  log_.info(who + "bench re-armed by the operator (interlock closed)");
  if (run_) {
    RunEvent stored;
    stored.run_id = run_->id;
    stored.wall_unix_s = unixNow();
    stored.severity = EventSeverity::kInfo;
    stored.kind = RearmedEvent::kEvent;
    stored.json = toJson(RearmedEvent{run_->id}).dump();
    if (auto added = store_->addEvent(stored); !added.ok) log_.error("store: " + added.message);
    server_->broadcast(RearmedEvent{run_->id});
    onPoll();  // a fresh observation, so a resume right after sees the closed interlock
  }
  return okReply(request.id, toJson(RearmReply{tableStatus()}));
}

// The table as last read: what the operator needs to see to re-arm or clear it.
TableStatus BenchDaemon::tableStatus() const {
  const drivers::TableReading& r = port_->lastReading();
  const char* interlock = r.interlock_tripped ? "tripped" : r.interlock_closed ? "closed" : "open";
  TableStatus t{interlock,    r.estop,      r.fault,     drivers::deviceStateName(table_->state()),
                std::nullopt, std::nullopt, std::nullopt};
  if (!port_->lastTableError().empty()) t.error = port_->lastTableError();
  if (table_answered_s_) t.age_s = wallNow() - *table_answered_s_;
  if (!r.axes.empty()) {  // the last read's axes (none after a read that got no answer)
    std::vector<double> angles;
    bool moving = false;
    for (const drivers::TableAxisReading& a : r.axes) {
      angles.push_back(a.angle * kRadToDeg);
      moving = moving || a.moving;
    }
    t.angles_deg = angles;
    t.moving = moving;
  }
  return t;
}

Reply BenchDaemon::status() const {
  StatusReply s;
  s.bench = bench_.name;
  s.state = run_ ? runnerStateName(run_->runner->state()) : "idle";
  s.imu_time_s = imu_last_t_;
  s.imu_lost_samples = imu_->decoder().counters().lost_samples;
  s.imu_bad_frames = imu_->decoder().counters().badFrames();
  s.imu_restarts = imu_->decoder().counters().restarts;
  s.table = tableStatus();
  s.lab = labStatus();
  if (const auto waiting = store_->queueList(); waiting.status.ok) {
    s.queued = waiting.value.size();  // plans in the queue (queue_list)
  }
  if (run_) {
    const PlanRunner& r = *run_->runner;
    const RunStep& shown = r.displayedStep();
    s.run = run_->id;
    s.plan = run_->plan_name;
    s.progress = run_->shownProgress();
    s.eta_s = r.etaS();
    s.step = StatusStep{shown.index, shown.label, calib::segmentKindName(shown.kind),
                        static_cast<std::int64_t>(r.steps().size())};
  }
  return okReply(nullptr, toJson(s));
}

// The plan library's directory is read off the loop too (it may sit on a network share).
std::optional<Reply> BenchDaemon::listPlans(const Request& request, ClientId client) {
  auto done = [this, client, id = request.id](std::vector<std::string> files) {
    server_->sendReply(client,
                       okReply(id, toJson(PlanListReply{bench_.plan_dir, std::move(files)})));
  };
  std::string why;
  if (!plans_->list(done, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

std::optional<Reply> BenchDaemon::validatePlan(const Request& request, ClientId client) {
  return withPlanText(request, client, std::get<ValidatePlanArgs>(request.args).plan,
                      [this, request](const std::string& name, const std::string& text) {
                        std::string why;
                        const auto loaded = loadPlan(name, text, bench_, &why);
                        if (!loaded) return errorReply(request.id, ErrorCode::kBadPlan, why);
                        const PlanSummary summary{
                            loaded->plan.name,
                            static_cast<std::int64_t>(loaded->motion.segments.size()),
                            loaded->motion.duration};
                        return okReply(request.id, toJson(ValidatePlanReply{summary}));
                      });
}

Reply BenchDaemon::results(const Request& request) {
  const auto& args = std::get<ResultsArgs>(request.args);
  if (!args.run) {
    const auto runs = store_->listRuns();
    if (!runs.status.ok) return errorReply(request.id, ErrorCode::kInternal, runs.status.message);
    RunListReply list;
    for (const RunInfo& r : runs.value) {
      list.runs.push_back(
          {r.id, r.start.plan_name, runStateName(r.state), r.exit_reason, r.started_unix_s});
    }
    return okReply(request.id, toJson(list));
  }
  const auto info = store_->runInfo(*args.run);
  if (!info.status.ok) return errorReply(request.id, ErrorCode::kNotFound, info.status.message);
  ResultFilter filter;
  filter.run_id = *args.run;
  const auto stored = store_->results(filter);
  RunResultsReply reply{*args.run, runStateName(info.value.state), info.value.exit_reason, {}};
  for (const StoredResult& r : stored.value) {
    json doc = json::parse(r.json, nullptr, false);
    if (doc.is_discarded()) doc = nullptr;  // unreadable stored text: null, never invalid JSON
    reply.results.push_back({r.kind, std::move(doc)});
  }
  return okReply(request.id, toJson(reply));
}

// Exports go only to a new directory under exports/ next to the database (the client names
// it, one path component): the daemon never writes where a client points it. Loading a whole
// run and writing it out takes long: it runs off the loop on a second store connection (WAL
// readers do not block the run's writer), and the reply follows.
std::optional<Reply> BenchDaemon::exportRun(const Request& request, ClientId client) {
  const auto& args = std::get<ExportArgs>(request.args);
  if (run_ && run_->id == args.run) run_->writer->flush();  // the export sees what is recorded
  const std::string name = args.dir.empty() ? "run-" + std::to_string(args.run) : args.dir;
  const std::optional<NamedGroup> group =
      fileGroup({bench_.control.command_group, bench_.control.read_group, ::geteuid()});
  auto job = [this, client, db = db_path_, run = args.run, name, id = request.id,
              group]() -> std::function<void()> {
    Reply r = exportToStateDir(db, run, name, id, group);
    return [this, client, r] { server_->sendReply(client, r); };
  };
  auto failed = [this, client, id = request.id](const std::string& what) {
    server_->sendReply(client, errorReply(id, ErrorCode::kInternal, "export failed: " + what));
  };
  std::string why;
  if (!exports_->run(job, failed, &why)) return errorReply(request.id, ErrorCode::kBusy, why);
  return std::nullopt;
}

}  // namespace imubench::daemon
