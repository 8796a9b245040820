// imubench-virtual-bench: one process holding one simulated bench world (virtual table with
// controller physics, thermal chamber with a first-order response, and the IMU simulator with
// the truth file's errors and extra physics) and serving it over the real protocols:
//   table   - Modbus TCP (several clients), optionally Modbus RTU and the serial command set on
//             pseudo-terminals (their slave paths are announced on stdout);
//   chamber - Modbus TCP;
//   IMU     - CAN frames on a SocketCAN interface (vcan) in the device file's layout, its
//             temperature lagging the chamber air by --imu-thermal-tau (the one lag model,
//             calib/model/thermal_lag.h) and, with --thermal-truth (imubench-thermal/1, the file
//             `imubench simulate --thermal-truth` reads), every coefficient following that
//             temperature and its rate through the simulator's own evaluation.
// Time runs --time-scale times faster than the wall clock. Faults can be injected from the
// command line, or while running by signal: SIGUSR1 drops every Modbus TCP connection,
// SIGUSR2 trips the table interlock, SIGRTMIN restarts the table controller (connections
// dropped, axes braked, modes off, interlock open; see VirtualTable::restart), SIGRTMIN+1
// restarts the IMU (silent, then its counter and time stamp from 0), SIGRTMIN+2 toggles a
// delay of every Modbus reply (--fault-signal-reply-delay-ms; table and chamber),
// --modbus-latency-ms/--modbus-jitter-ms give every Modbus round trip a latency (half each way),
// --host-watchdog-timeout sets the table controller's host watchdog (docs/devices.md).
// SIGRTMIN+3 toggles the IMU's silence (no frames; its clock runs on), SIGRTMIN+4 sends the
// chamber towards --fault-chamber-runaway (a setpoint changed behind the controller's back,
// as a front panel or a controller fault would). Announcements go to stdout (one line each,
// for scripts); events to syslog and stderr. Stops on SIGINT/SIGTERM.
#include <signal.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "calib/simulator.h"
#include "daemon/logging.h"
#include "drivers/imu_layout.h"
#include "drivers/modbus_device_models.h"
#include "drivers/modbus_server.h"
#include "drivers/virtual_imu_can.h"
#include "drivers/virtual_table_scpi.h"
#include "drivers/virtual_world.h"
#include "io/thermal_file.h"
#include "io/truth_file.h"
#include "nav/rotation.h"

namespace {

using namespace imubench;
using namespace imubench::drivers;

struct Args {
  std::string table_file, serial_table_file, chamber_file;
  std::string host = "127.0.0.1";
  int table_port = -1;  // -1: the device file's port
  int chamber_port = -1;
  bool table_rtu = false;
  int rtu_unit = 1;
  double time_scale = 1.0;
  double ambient_c = 20.0;
  std::string imu_layout_file, can_interface = "vcan0", truth_file;
  std::string thermal_truth_file;  // imubench-thermal/1; empty: coefficients constant
  // The IMU's thermal time constant behind the chamber air, s: its mount's, which no device
  // file states (0: the IMU is at the air temperature).
  double imu_thermal_tau_s = 0.0;
  double imu_rate_hz = 0.0;  // 0: the layout's sample period
  std::uint64_t seed = 1;
  // The site the IMU senses (gravity, Earth rate): the shipped bench file's
  // (daemon/benches/virtual-bench.toml), so the daemon's calibration assumes where it is.
  double latitude_deg = 55.7558;
  double height_m = 150.0;
  std::string noise = "none";  // IMU noise model by name (calib::NoiseModel::byName)
  // faults
  double reply_delay_ms = 0.0;
  bool drop_replies = false;
  double trip_after_s = -1.0;
  std::string trip_reason = "injected interlock trip (virtual bench)";
  int imu_drop_every = 0, imu_corrupt_every = 0;
  std::int64_t imu_stop_after = -1;
  double imu_restart_after_s = -1.0;
  double imu_restart_silence_s = 0.2;
  double imu_wrap_at_s = -1.0;
  double signal_reply_delay_ms = 2000.0;  // SIGRTMIN+2 toggles this delay
  // The table controller's host-watchdog timeout, s, as configured at the controller (0: the
  // device file's).
  double host_watchdog_timeout_s = 0.0;
  // Modbus link latency: each round trip takes latency +- jitter, half before the controller
  // reads or acts (the request's way), half after (the reply's), ms.
  double modbus_latency_ms = 0.0, modbus_jitter_ms = 0.0;
  double chamber_runaway_c = 120.0;  // SIGRTMIN+4: where the chamber heads
};

void announce(const std::string& line) {
  std::cout << line << std::endl;  // flushed: scripts wait for these lines
}

// Streams the simulator's samples whose stamps have passed on the virtual clock, one batch
// per tick (the sample counter defines the timing: t_k = k / rate).
class ImuStreamer {
 public:
  ImuStreamer(VirtualWorld& world, std::unique_ptr<calib::ImuSimulator> sim,
              std::unique_ptr<VirtualImuCan> can, const daemon::Logger& log)
      : world_(world), sim_(std::move(sim)), can_(std::move(can)), log_(log) {}
  ~ImuStreamer() { stop(); }
  void start() {
    thread_ = std::thread([this] { run(); });
  }
  // Restarts the IMU at its next sample (thread-safe).
  void requestRestart() { can_->requestRestart(); }
  // Silent: samples are made (the IMU's clock runs on) but no frame is sent. Returns the new
  // state (thread-safe).
  bool toggleSilence() {
    bool was = silent_.load();
    while (!silent_.compare_exchange_weak(was, !was)) {
    }
    return !was;
  }
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

 private:
  void run() {
    std::vector<nav::ImuSample> batch;
    bool reported = false;
    for (;;) {
      world_.withMotion([&](const calib::Motion&, double now) {
        while (sim_->nextTime() <= now) batch.push_back(sim_->next());
        return 0;
      });
      if (silent_) batch.clear();
      if (!batch.empty()) {
        const Status s = can_->sendSamples(batch);
        if (!s.ok && !reported) log_.error("virtual IMU: " + s.message);
        reported = reported || !s.ok;
        batch.clear();
      }
      std::unique_lock lock(mu_);
      // Pacing tick of the stream (not a synchronisation): 5 ms of wall time.
      if (cv_.wait_for(lock, std::chrono::milliseconds(5), [this] { return stopping_; })) return;
    }
  }
  VirtualWorld& world_;
  std::unique_ptr<calib::ImuSimulator> sim_;
  std::unique_ptr<VirtualImuCan> can_;
  const daemon::Logger& log_;
  std::thread thread_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::atomic<bool> silent_{false};
};

// The signals the virtual bench waits for (blocked in main before any thread starts):
// stop, and the fault injections of the header comment.
sigset_t benchSignals() {
  sigset_t set;
  sigemptyset(&set);
  for (int sig : {SIGINT, SIGTERM, SIGUSR1, SIGUSR2, SIGRTMIN, SIGRTMIN + 1, SIGRTMIN + 2,
                  SIGRTMIN + 3, SIGRTMIN + 4}) {
    sigaddset(&set, sig);
  }
  return set;
}

// The device files named on the command line, checked against each other. nullopt + *why.
struct Devices {
  TableDeviceSpec table;
  ChamberDeviceSpec chamber;
  std::optional<TableDeviceSpec> serial_table;
};

std::optional<Devices> loadDevices(const Args& a, std::string* why) {
  io::Diagnostics tdiag(a.table_file);
  auto table = loadTableDevice(a.table_file, tdiag);
  if (!table) {
    *why = "table device file refused:\n" + tdiag.str();
    return std::nullopt;
  }
  if (table->transport.kind == TransportKind::kSerialScpi) {
    *why = a.table_file +
           ": --table needs a Modbus register map (give serial command sets with --serial-table)";
    return std::nullopt;
  }
  io::Diagnostics cdiag(a.chamber_file);
  auto chamber = loadChamberDevice(a.chamber_file, cdiag);
  if (!chamber) {
    *why = "chamber device file refused:\n" + cdiag.str();
    return std::nullopt;
  }
  Devices d{std::move(*table), std::move(*chamber), std::nullopt};
  if (!a.serial_table_file.empty()) {
    io::Diagnostics sdiag(a.serial_table_file);
    d.serial_table = loadTableDevice(a.serial_table_file, sdiag);
    if (!d.serial_table) {
      *why = "serial table device file refused:\n" + sdiag.str();
      return std::nullopt;
    }
    if (d.serial_table->transport.kind != TransportKind::kSerialScpi ||
        d.serial_table->kind != d.table.kind) {
      *why = a.serial_table_file +
             ": --serial-table needs a serial-scpi file for a table with as many axes as --table";
      return std::nullopt;
    }
  }
  return d;
}

// The IMU simulator on the world's motion, streaming CAN frames (started). null + *why.
std::unique_ptr<ImuStreamer> startImu(const Args& a, VirtualWorld& world, const daemon::Logger& log,
                                      std::string* why) {
  io::Diagnostics idiag(a.imu_layout_file);
  auto layout = loadImuLayoutFile(a.imu_layout_file, idiag);
  if (!layout) {
    *why = "IMU device file refused:\n" + idiag.str();
    return nullptr;
  }
  calib::BenchWorld bench;
  if (!a.truth_file.empty()) {
    auto t = io::readTruthFile(a.truth_file);
    if (!t.status.ok) {
      *why = t.status.message;
      return nullptr;
    }
    bench.truth = t.value;
  }
  if (!a.thermal_truth_file.empty()) {
    const io::ThermalFileResult t = io::readThermalFile(a.thermal_truth_file);
    if (!t.status.ok) {
      *why = "--thermal-truth " + t.status.message;
      return nullptr;
    }
    bench.thermal = t.value.coefficients;
  }
  bench.noise = *calib::NoiseModel::byName(a.noise);  // checked by CLI11
  bench.site.latitude_rad = a.latitude_deg * kDegToRad;
  bench.site.height_m = a.height_m;
  calib::SimOptions opts;
  opts.imu_rate_hz = a.imu_rate_hz > 0 ? a.imu_rate_hz : 1.0 / layout->sample_period_s;
  opts.seed = a.seed;
  auto sim = world.withMotion([&](const calib::Motion& m, double) {
    return calib::ImuSimulator::Create(bench, &m, opts, why);
  });
  if (!sim) {
    *why = "IMU simulator: " + *why;
    return nullptr;
  }
  VirtualImuOptions io;
  io.interface = a.can_interface;
  io.faults.drop_frame_every = a.imu_drop_every;
  io.faults.corrupt_frame_every = a.imu_corrupt_every;
  io.faults.stop_after = a.imu_stop_after;
  io.faults.restart_at_s = a.imu_restart_after_s;
  io.faults.restart_silence_s = a.imu_restart_silence_s;
  io.wrap_at_s = a.imu_wrap_at_s;
  if (!io.IsValid(why)) {
    *why = "IMU: " + *why;
    return nullptr;
  }
  auto can = std::make_unique<VirtualImuCan>(*layout, io);
  if (Status s = can->open(); !s.ok) {
    *why = "IMU on " + a.can_interface + ": " + s.message;
    return nullptr;
  }
  auto imu = std::make_unique<ImuStreamer>(world, std::move(sim), std::move(can), log);
  imu->start();
  announce("imu can " + a.can_interface + " layout " + a.imu_layout_file + " rate " +
           std::to_string(opts.imu_rate_hz) + " Hz");
  return imu;
}

// What the running bench's fault injections act on.
struct FaultTargets {
  VirtualWorld& world;
  ModbusServer& table_tcp;
  ModbusServer& chamber_tcp;
  ImuStreamer* imu;   // null without an IMU
  LinkFaults& links;  // the Modbus servers' (table and chamber)
};

// SIGRTMIN+2, +3, +4: reply delay on/off, IMU silence on/off, chamber runaway.
void injectToggled(int sig, const Args& a, const FaultTargets& f, const daemon::Logger& log) {
  if (sig == SIGRTMIN + 2) {
    const bool on = f.links.reply_delay_s == 0.0;
    f.links.reply_delay_s = on ? a.signal_reply_delay_ms / 1000.0 : 0.0;
    log.warning(on ? "fault injection: every Modbus reply delayed by " +
                         std::to_string(static_cast<int>(a.signal_reply_delay_ms)) + " ms"
                   : std::string("fault injection: Modbus replies on time again"));
  }
  if (sig == SIGRTMIN + 3 && f.imu != nullptr) {
    log.warning(f.imu->toggleSilence() ? "fault injection: the IMU goes silent"
                                       : "fault injection: the IMU sends again");
  }
  if (sig == SIGRTMIN + 4) {
    f.world.withChamber([&](VirtualChamber& c, double now) {
      c.setRampRate(now, 0.0);
      c.setSetpoint(now, a.chamber_runaway_c);
      c.run(now, true);
      return 0;
    });
    log.warning("fault injection: the chamber runs away towards " +
                std::to_string(a.chamber_runaway_c) + " degC");
  }
}

// Waits for SIGINT/SIGTERM, carrying out the fault-injection signals and the scheduled
// interlock trip (--fault-trip-after) on the way.
void serveUntilStopped(const Args& a, const FaultTargets& f, const daemon::Logger& log) {
  const sigset_t set = benchSignals();
  auto trip = [&] {
    f.world.withTable([&](VirtualTable& t, double now) {
      t.trip(now, a.trip_reason);
      return 0;
    });
    log.warning("fault injection: table interlock tripped: " + a.trip_reason);
  };
  bool tripped = a.trip_after_s < 0;
  for (;;) {
    timespec ts{1, 0};
    if (!tripped) {
      const double wall = std::max(0.0, (a.trip_after_s - f.world.now()) / a.time_scale);
      ts.tv_sec = static_cast<time_t>(wall);
      ts.tv_nsec = static_cast<long>((wall - std::floor(wall)) * 1e9);
    }
    const int sig = sigtimedwait(&set, nullptr, tripped ? nullptr : &ts);
    if (sig == SIGINT || sig == SIGTERM) return;
    if (sig == SIGUSR1) {
      log.warning("fault injection: dropping every Modbus TCP connection");
      f.table_tcp.dropConnections();
      f.chamber_tcp.dropConnections();
    }
    if (sig == SIGUSR2) trip();
    injectToggled(sig, a, f, log);
    if (sig == SIGRTMIN + 1 && f.imu != nullptr) {
      log.warning("fault injection: IMU restart (silent, then counter and time stamp from 0)");
      f.imu->requestRestart();
    }
    if (sig == SIGRTMIN) {
      log.warning("fault injection: table controller restart");
      f.world.withTable([](VirtualTable& t, double now) {
        t.restart(now);
        return 0;
      });
      f.table_tcp.dropConnections();
    }
    if (!tripped && f.world.now() >= a.trip_after_s) {
      trip();
      tripped = true;
    }
  }
}

// Starts a device's Modbus TCP server on the port given on the command line (port >= 0), else
// on its device file's, and announces where it listens ("table modbus-tcp HOST:PORT device
// FILE"); the error names the device.
Status startTcpDevice(ModbusServer& server, const std::string& what, const std::string& host,
                      int port, int file_port, const std::string& device_file) {
  if (Status s = server.startTcp(host, port >= 0 ? port : file_port); !s.ok)
    return Status::Error(what + ": " + s.message);
  announce(what + " modbus-tcp " + host + ":" + std::to_string(server.port()) + " device " +
           device_file);
  return Status::Ok();
}

int run(const Args& a) {
  daemon::Logger log("imubench-virtual-bench", /*also_stderr=*/true);
  auto fail = [&](const std::string& m) {
    log.error(m);
    return 1;
  };
  std::string why;
  std::optional<Devices> dev = loadDevices(a, &why);
  if (!dev) return fail(why);
  if (a.host_watchdog_timeout_s > 0.0) {
    if (!dev->table.watchdog.declared()) {
      return fail("--host-watchdog-timeout: the table's device file declares no [host_watchdog]");
    }
    dev->table.watchdog.timeout_s = a.host_watchdog_timeout_s;
  }
  if (a.modbus_jitter_ms > a.modbus_latency_ms) {
    return fail("--modbus-jitter-ms must not exceed --modbus-latency-ms");
  }
  VirtualWorld world(dev->table, dev->chamber, a.time_scale, a.ambient_c, a.imu_thermal_tau_s);
  LinkFaults faults;
  faults.reply_delay_s = a.reply_delay_ms / 1000.0;
  faults.drop_replies = a.drop_replies;
  faults.latency_s = a.modbus_latency_ms / 1000.0;
  faults.jitter_s = a.modbus_jitter_ms / 1000.0;
  EventSink sink = [&log](const std::string& m) { log.warning(m); };

  VirtualTableRegisters table_regs(world, dev->table, sink);
  ModbusServer table_tcp(table_regs, faults, sink);
  if (Status s = startTcpDevice(table_tcp, "table", a.host, a.table_port, dev->table.transport.port,
                                a.table_file);
      !s.ok)
    return fail(s.message);
  std::unique_ptr<ModbusServer> table_rtu;
  if (a.table_rtu) {
    table_rtu = std::make_unique<ModbusServer>(table_regs, faults, sink);
    if (Status s = table_rtu->startRtu(a.rtu_unit); !s.ok) return fail("table RTU: " + s.message);
    announce("table modbus-rtu " + table_rtu->ptyPath() + " unit " + std::to_string(a.rtu_unit));
  }
  std::unique_ptr<VirtualTableScpi> table_serial;
  if (dev->serial_table) {
    table_serial = std::make_unique<VirtualTableScpi>(world, *dev->serial_table, faults, sink);
    if (Status s = table_serial->start(); !s.ok) return fail("table serial: " + s.message);
    announce("table serial " + table_serial->ptyPath() + " device " + a.serial_table_file);
  }
  VirtualChamberRegisters chamber_regs(world, dev->chamber, sink);
  ModbusServer chamber_tcp(chamber_regs, faults, sink);
  if (Status s = startTcpDevice(chamber_tcp, "chamber", a.host, a.chamber_port,
                                dev->chamber.transport.port, a.chamber_file);
      !s.ok)
    return fail(s.message);

  std::unique_ptr<ImuStreamer> imu;
  if (!a.imu_layout_file.empty()) {
    imu = startImu(a, world, log, &why);
    if (!imu) return fail(why);
  }
  announce("ready time-scale " + std::to_string(a.time_scale));
  serveUntilStopped(a, FaultTargets{world, table_tcp, chamber_tcp, imu.get(), faults}, log);
  log.info("stopping");
  if (imu) imu->stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  CLI::App app{"imubench-virtual-bench: a simulated table, chamber and IMU over real protocols"};
  app.add_option("--table", a.table_file, "table device file with a Modbus register map")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--chamber", a.chamber_file, "chamber device file")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--serial-table", a.serial_table_file,
                 "also serve the table's serial command set (serial-scpi device file) on a pty")
      ->check(CLI::ExistingFile);
  app.add_flag("--table-rtu", a.table_rtu,
               "also serve the table's register map over Modbus RTU "
               "on a pty");
  app.add_option("--rtu-unit", a.rtu_unit, "Modbus RTU unit id")->check(CLI::Range(1, 247));
  app.add_option("--host", a.host, "address the Modbus TCP servers listen on");
  app.add_option("--table-port", a.table_port,
                 "table Modbus TCP port (0: ephemeral; default: "
                 "the device file's)");
  app.add_option("--chamber-port", a.chamber_port, "chamber Modbus TCP port (0: ephemeral)");
  app.add_option("--time-scale", a.time_scale, "simulated seconds per wall second")
      ->check(CLI::PositiveNumber);
  app.add_option("--ambient", a.ambient_c, "ambient temperature, degC");
  app.add_option("--imu", a.imu_layout_file, "IMU device file (CAN layout): stream the IMU")
      ->check(CLI::ExistingFile);
  app.add_option("--can", a.can_interface, "SocketCAN interface for the IMU");
  app.add_option("--truth", a.truth_file, "truth JSON (sensor/table errors, extra physics)")
      ->check(CLI::ExistingFile);
  app.add_option("--thermal-truth", a.thermal_truth_file,
                 "imubench-thermal/1 file: the IMU's coefficients over temperature and its rate")
      ->check(CLI::ExistingFile);
  app.add_option("--imu-thermal-tau", a.imu_thermal_tau_s,
                 "the IMU's thermal time constant behind the chamber air, s (default 0)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--imu-rate", a.imu_rate_hz, "IMU rate, Hz (default: the layout's)");
  app.add_option("--seed", a.seed, "IMU noise seed");
  app.add_option("--latitude", a.latitude_deg,
                 "site latitude, deg (the IMU senses its gravity and Earth rate; default: the "
                 "shipped bench file's)")
      ->check(CLI::Range(-90.0, 90.0));
  app.add_option("--height", a.height_m, "site height, m (default: the shipped bench file's)");
  app.add_option("--noise", a.noise, "IMU noise: none|nav-grade|nav-grade-drift|tactical|consumer")
      ->check(CLI::IsMember({"none", "nav-grade", "nav-grade-drift", "tactical", "consumer"}));
  app.add_option("--fault-reply-delay-ms", a.reply_delay_ms, "delay every Modbus/serial reply")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--fault-drop-replies", a.drop_replies, "never answer Modbus/serial requests");
  app.add_option("--fault-signal-reply-delay-ms", a.signal_reply_delay_ms,
                 "the reply delay SIGRTMIN+2 switches on and off, ms (default 2000)")
      ->check(CLI::PositiveNumber);
  app.add_option("--host-watchdog-timeout", a.host_watchdog_timeout_s,
                 "the table controller's host-watchdog timeout, s (default: the device file's)")
      ->check(CLI::PositiveNumber);
  app.add_option("--modbus-latency-ms", a.modbus_latency_ms,
                 "every Modbus round trip takes this long, half before the controller reads "
                 "or acts, half after, ms")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--modbus-jitter-ms", a.modbus_jitter_ms,
                 "each round trip's latency varies uniformly by +- this, ms")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--fault-chamber-runaway", a.chamber_runaway_c,
                 "where SIGRTMIN+4 sends the chamber, degC (default 120)");
  app.add_option("--fault-trip-after", a.trip_after_s,
                 "trip the table interlock at this simulated time, s");
  app.add_option("--fault-imu-drop-every", a.imu_drop_every, "drop a frame of every Nth sample");
  app.add_option("--fault-imu-corrupt-every", a.imu_corrupt_every,
                 "corrupt a frame of every Nth sample");
  app.add_option("--fault-imu-stop-after", a.imu_stop_after, "the IMU stops after N samples");
  app.add_option("--fault-imu-restart-after", a.imu_restart_after_s,
                 "the IMU restarts at this simulated time, s (also SIGRTMIN+1 at any time)");
  app.add_option("--fault-imu-restart-silence", a.imu_restart_silence_s,
                 "how long a restarting IMU is silent, simulated s (default 0.2)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--imu-wrap-at", a.imu_wrap_at_s,
                 "start the IMU counter and time stamp so that both wrap at this simulated "
                 "time, s")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  // Signals are taken synchronously by the main thread (sigtimedwait): block them before any
  // server thread starts so every thread inherits the mask.
  const sigset_t set = benchSignals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);
  return run(a);
}
