// BenchDaemon (daemon/bench_daemon.h), in parts by concern; bench_daemon_internal.h holds what
// they share (LoadedPlan, BenchDaemon::ActiveRun, helpers):
//   bench_daemon.cpp           construction, start/stop, the loop wiring, the shared helpers
//   bench_daemon_intake.cpp    the IMU and the table: intake, polling, steps, run events, status
//   bench_daemon_commands.cpp  the control socket: commands, starting and resuming runs
//   bench_daemon_results.cpp   calibration (online, final, per point) and the follow-up experiment
//   bench_daemon_queue.cpp     the plan queue and the remaining commands (status, results, export)

#include "daemon/bench_daemon.h"

#include <fcntl.h>
#include <sys/epoll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "daemon/bench_daemon_internal.h"
#include "daemon/plan_check.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::daemon {

namespace bench_daemon_internal {

double unixNow() {
  return drivers::unixTimeS();
}

// errno in words: strerror_r (GNU: returns the text, in buf or static), not strerror, which
// may share its buffer with the off-loop threads.
std::string errnoWords(int err) {
  char buf[256];
  return ::strerror_r(err, buf, sizeof buf);
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

}  // namespace bench_daemon_internal

using bench_daemon_internal::errnoWords;

namespace {

namespace fs = std::filesystem;

// Exports in progress at once: each holds a whole run in memory while it writes it.
constexpr std::size_t kMaxPendingExports = 2;
// Calibrations in progress at once: a run's estimate (one at a time per run), the previous
// run's end-of-plan calibration, and the next queued run's first estimate.
constexpr std::size_t kMaxPendingCalibrations = 3;

std::chrono::nanoseconds seconds(double s) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(s * 1e9));
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

}  // namespace

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

}  // namespace imubench::daemon
