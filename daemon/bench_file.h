// The bench file: what one imubenchd instance drives. One TOML file per bench names the device
// files of its table, chamber and IMU, where they are reached, the site, the bench's own
// limits and timeouts, and where the daemon keeps its database and control socket.
//
// Grammar (every dimensioned value is a string with its unit, as in plan and device files;
// relative paths are relative to the bench file's directory):
//
//   [bench]
//   name = "lab2-bench-a"                        # required; shown in status and stored per run
//   storage = "/var/lib/imubench/imubench.db"    # SQLite database (WAL)
//   control_socket = "/run/imubench/control.sock"  # unused when systemd passes the socket
//   plan_dir = "plans"                           # optional: the plan library: what list_plans
//                                                #   shows, the only plans started by path
//
//   [site]
//   latitude = "55.7558 deg"                     # required
//   height = "150 m"                             # required
//   gravity = 9.8155                             # optional, m/s^2 (measured); else WGS-84
//   outer_axis_heading = "90 deg"                # two-axis tables; clockwise from North
//
//   [table]
//   device = "devices/tables/imubench-ref-2axis-tcp.toml"   # required
//   host = "10.0.0.20"                           # optional endpoint overrides of the device
//   port = 502                                   #   file (Modbus TCP) ...
//   path = "/dev/ttyUSB0"                        #   ... or its serial device (RTU, serial)
//   max_rate = "30 deg/s"                        # optional bench limits: tighter than the
//   max_accel = "10 deg/s^2"                     #   device's, never looser
//   errors = "certification/table.json"          # optional: the table's certified errors (a
//                                                #   coefficient file's "table" section,
//                                                #   interchange.md) that every calibration of
//                                                #   this bench takes as known; without them a
//                                                #   direct plan on a table with errors gives an
//                                                #   unusable fit and no verdict
//
//   [chamber]                                    # optional: a bench without a chamber
//   device = "devices/chambers/watlow-f4-style.toml"
//   host = "10.0.0.21"
//   port = 502
//   safe_setpoint = "23 degC"                    # where abort and faults leave it
//   over_temperature = "90 degC"                 # measured above this -> safe state + alarm
//   poll_period = "1 s"                          # how often it is read and stored in a run
//
//   [imu]
//   layout = "devices/imus/navgrade_fd.toml"     # required: the CAN frame layout
//   interface = "can0"                           # required: the SocketCAN interface
//   serial = "SN-0001"                           # optional; results are stored per serial
//   max_clock_ratio = 2   # optional, integer 1..1000: how many times faster than the receive
//                         #   clock the IMU's clock may run (restart and wrap judgement, also
//                         #   of a crash resume); the virtual bench at --time-scale S: >= S
//
//   [safety]
//   comm_timeout = "1 s"      # table or chamber silent longer -> stop motion, pause, alarm
//   imu_timeout = "0.5 s"     # no IMU frame for longer -> pause, alarm (recording goes on)
//
//   [control]                 # optional: the control socket's connections
//   idle_timeout = "600 s"    # a connection without a request this long is closed, unless it
//                             #   is subscribed and reads its events; "0 s": never
//   command_group = "imubench"       # optional: only members (and root, and the daemon's own
//                                    #   user) may start/pause/resume/abort/rearm and change
//                                    #   the queue; everyone who reaches the socket may still
//                                    #   send the emergency stop (stop) and ping
//   read_group = "imubench-view"     # optional, needs command_group: members (and the command
//                                    #   group's) may read: status, watch, results, export,
//                                    #   list_plans, validate_plan, queue_list; exports and the
//                                    #   database are made readable by this group
//   max_connections_per_uid = 4      # optional: connections one uid may hold (root and the
//                                    #   daemon's user excepted); a new one beyond it closes
//                                    #   that uid's least recently active one; 0: no limit
//   stop_socket = "/run/imubench/control.sock.stop"  # optional, default: control_socket +
//                                    #   ".stop" (also under systemd): a socket that takes only
//                                    #   stop, served before anything else; `imubench stop`
//                                    #   uses it
//   [lab]                     # optional: mirror runs and results to the lab's PostgreSQL
//   database = "postgresql://bench_a@lab-db:5432/lab"   # libpq URI, never with a password in it
//   password_file = "/etc/imubench/lab.pass"  # optional: the password (first line), owned by the
//                             #   daemon's user, mode 0600; else libpq's ~/.pgpass or service file
//                             #   The SQLite store stays the source of truth (lab/shipper.h).
//   mirror_samples = true     # optional, default false: also the raw IMU, table and chamber
//                             #   samples (COPY batches, lab/sample_shipper.h)
//   [acceptance]              # optional: the IMU's pass/fail limits, checked after a plan's
//                             #   calibration (daemon/run_calibration.h): |estimate| <= limit
//   "gyro.bias" = "0.01 deg/h"       # a parameter's flat name (interchange.md), or a group:
//   "accel.scale" = "100 ppm"        #   every parameter under it ("gyro.bias" = x, y, z);
//   "accel.misalignment.xy" = "30 arcsec"   # scales are judged as |scale - 1|; the unit is
//                                    #   the parameter's display unit: ppm, ug, deg/h, arcsec
//   [explain]                 # optional: what the daemon does with the end-of-plan analysis
//   follow_up = "propose"     # "off": nothing; "propose" (default): when the analysis finds
//                             #   unseparable groups, the plan that separates them (within this
//                             #   bench's [table] limits) is stored with the run's results
//                             #   (`imubench queue accept RUN` queues it); "queue": it is also
//                             #   appended to the plan queue and runs next (docs/explain.md
//                             #   "In the daemon")
//
//   The control socket has 16 slots for every command and 2 reserved for stop, status and ping,
//   given only to root, the daemon's user and command_group members (to everyone without a
//   command_group). Without command_group anyone who can reach the socket may send every command:
//   the socket file's mode (0660, group imubench) is the only gate, as before these keys. With a
//   command_group and other users meant to read or stop, the socket must let them connect
//   (SocketMode=0666 in systemd/imubenchd.socket, or a group they share). Group names are
//   resolved when the bench file is loaded (an unknown group is an error at its key). Rules:
//   daemon/control_rights.h.
//
// Loading never throws: every problem is a diagnostic "file:line:column: reason", including
// problems inside the referenced device files, and the bench is refused (nullopt).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/table_model.h"
#include "daemon/control_rights.h"
#include "drivers/device_file.h"
#include "drivers/imu_decoder.h"
#include "drivers/imu_layout.h"
#include "io/toml_diagnostics.h"
#include "nav/earth.h"

namespace imubench::daemon {

struct BenchSafety {
  double comm_timeout_s = 1.0;  // longer than the device's retry chain, short enough to stop
  double imu_timeout_s = 0.5;   // tens of IMU periods: a silent IMU, not one late frame
};

struct BenchChamber {
  drivers::ChamberDeviceSpec device;
  double safe_setpoint_c = 23.0;     // lab ambient: safe for the IMU and the operator
  double over_temperature_c = 90.0;  // above any plan's setpoint, below damage
  // Chamber reads (and stored chamber samples) during a run: a chamber changes over minutes
  // (time constants of minutes, ramps of a few degC/min), so 1 s resolves it and keeps the
  // controller's Modbus traffic far below the table's 50 reads a second.
  double poll_period_s = 1.0;
  // [chamber] imu_time_constant: how far the IMU's own temperature lags the chamber air (its
  // housing and mounting), s; with the chamber device file's time_constant it is the lag the
  // plan's soak and ramp times are expanded with (calib/model/thermal_lag.h). 0: no lag known.
  double imu_time_constant_s = 0.0;
};

// Ten days: any longer is "never", which "0 s" says.
inline constexpr double kMaxIdleTimeoutS = 864000.0;
// [imu] max_clock_ratio at most (the virtual bench's time scales are far below).
inline constexpr std::int64_t kMaxClockRatio = 1000;
// [control] max_connections_per_uid at most (0: no limit).
inline constexpr std::int64_t kMaxConnectionsPerUid = 1024;

struct BenchControl {
  // ControlServerOptions::idle_timeout_s: leaked connections free their slots; ten minutes
  // outlasts an operator pausing at a prompt.
  double idle_timeout_s = 600.0;
  // Who may command and who may read (daemon/control_rights.h); absent: everyone who reaches
  // the socket may do everything (the socket's file mode is the gate).
  std::optional<NamedGroup> command_group;
  std::optional<NamedGroup> read_group;
  // ControlServerOptions::max_connections_per_uid: one user cannot hold every slot.
  std::size_t max_connections_per_uid = 4;
  // The stop socket; empty: the control socket's path + ".stop".
  std::string stop_socket;
};

struct BenchImu {
  drivers::ImuLayout layout;
  std::string layout_file;
  std::string interface;  // SocketCAN interface, e.g. "can0" or "vcan0"
  std::string serial;     // empty: unknown
  // How many times faster than the receive clock the IMU's clock may run
  // (drivers::ImuDecoderOptions::max_clock_ratio, default 2: a real IMU). The virtual bench
  // at --time-scale S runs its IMU S times faster: S or more, or every silence of its IMU and
  // every crash resume across a wrap of its time stamp is taken for a restart.
  double max_clock_ratio = drivers::ImuDecoderOptions{}.max_clock_ratio;
};

// One acceptance limit ([acceptance]): every flat parameter name equal to `parameter` or
// under it ("gyro.bias" -> gyro.bias.x/y/z) must satisfy |estimate| <= limit (SI; scale
// factors as |scale - 1|).
struct AcceptanceLimit {
  std::string parameter;
  double limit = 0.0;  // SI
  std::string text;    // as written, e.g. "0.01 deg/h"
};

// [lab]: where the bench mirrors its store (issue 30, lab/shipper.h).
struct BenchLab {
  std::string database;       // libpq connection URI or key=value string, without a password
  std::string password_file;  // empty: libpq's password or service file
  // Also mirror the raw IMU, table and chamber samples (COPY batches, lab/sample_shipper.h).
  // Default false: a 2 kHz IMU adds ~7 million rows an hour to the lab database.
  bool mirror_samples = false;
};

// [explain] follow_up: what the daemon does when a run's end-of-plan analysis reports groups
// its recording cannot separate (daemon/follow_up.h).
enum class FollowUpPolicy {
  kOff,      // nothing beyond the analysis
  kPropose,  // the separating plan is designed and stored with the run's results
  kQueue,    // ... and appended to the plan queue (it runs next)
};
const char* followUpPolicyName(FollowUpPolicy p);

struct BenchExplain {
  // "propose": designing costs seconds of a worker and moves nothing, while the operator sees
  // what would settle the groups; queueing a plan that moves the table is the bench owner's
  // choice ("queue"), never the default.
  FollowUpPolicy follow_up = FollowUpPolicy::kPropose;
};

struct BenchConfig {
  std::string file;  // the bench file as given
  std::string name;
  std::string storage_path;
  std::string control_socket;
  std::string plan_dir;  // empty: none (clients send every plan as text)
  nav::Site site;
  double outer_axis_heading_rad = 0.5 * 3.141592653589793;  // East
  // The table's device spec with the bench's endpoint overrides applied and its limits
  // tightened to the bench's: what the daemon enforces, whatever the controller allows.
  drivers::TableDeviceSpec table;
  // [table] reading_gap: two stored table readings further apart than their cadence plus this
  // (wall time) while the plan runs are a gap in the table data: an alarm, and the step runs
  // again (as after a gap of the IMU stream: BenchDaemon::onRecordingGap). The cadence is the
  // poll period or, on a slow link, the median duration of the last 9 polls (8 round trips on
  // a two-axis Modbus table: 0.4 s at 50 ms latency), plus the time the daemon spent commanding
  // the devices and reading the chamber between the two readings (DriverBenchPort::busyS: a
  // step's start is a dozen round trips). 0.2 s: ten polls at the default period, so a late
  // poll or two pass, while a controller that stops answering for a while (shorter than
  // comm_timeout) or a loop held up (the overload that lost stretches of table.csv, issue 28)
  // does not pass silently. Wall time, not IMU time: a virtual bench at 20x has polls 0.4 s of
  // IMU time apart. (A test machine that stalls for a second at a time needs more: the e2e
  // harness sets 3 s for tests about other things.)
  double table_reading_gap_s = 0.2;
  // [table] errors: the table's certified errors (base tilt, nonorthogonality, mounting, encoder
  // zeros of this table's kind), known to every calibration of the bench's runs
  // (calib::CalibrationRequest::known_table_errors). The direct method takes the table as
  // nominal: on a table with errors of tens of arcseconds its fit does not reach the noise and
  // the run gets no verdict, unless the errors are given here. Unset: unknown (the
  // navigation-based calibration estimates them itself).
  std::optional<calib::TableErrors> table_errors;
  std::string table_errors_file;  // as resolved, for reports
  std::optional<BenchChamber> chamber;
  BenchImu imu;
  BenchSafety safety;
  BenchControl control;
  std::vector<AcceptanceLimit> acceptance;  // empty: no verdict (results say so)
  std::optional<BenchLab> lab;              // unset: no lab mirror
  BenchExplain explain;
};

// Parses bench text; device files are resolved against base_dir. file_name names the text in
// diagnostics.
std::optional<BenchConfig> parseBenchFile(std::string_view text, std::string_view file_name,
                                          const std::string& base_dir, io::Diagnostics& diag);
// Reads and parses a bench file.
std::optional<BenchConfig> loadBenchFile(const std::string& path, io::Diagnostics& diag);

}  // namespace imubench::daemon
