// Device description files: one TOML file per device model (drivers/devices/tables/,
// drivers/devices/chambers/) says how to talk to it: transport, addresses, register map or
// command set, scaling, word order, limits, timeouts and retry policy. A new vendor's table or
// chamber in a protocol family we already speak is a new file, not new code.
//
// Loading never throws and never crashes on bad input: every problem becomes a
// io::Diagnostic "file:line:column: reason" and the device is refused (nullopt).
// All values inside are SI (rad, rad/s, s, degC, degC/s); units are required in the file.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/model/motion.h"
#include "io/toml_diagnostics.h"

namespace imubench::drivers {

// How a driver or a virtual device reports what happened (a retry, a fault, an injected
// fault): the program passes a sink that logs (daemon::Logger); library code never prints.
using EventSink = std::function<void(const std::string& message)>;

enum class TransportKind { kModbusTcp, kModbusRtu, kSerialScpi };
const char* transportKindName(TransportKind k);

// What a driver does when a request fails (timeout, no reply, connection lost).
struct RetryPolicy {
  double timeout_s = 0.5;  // reply timeout of one attempt: longer than the slowest legal reply
  int retries = 2;         // attempts after the first one before the driver enters kFault
  bool reconnect = true;   // reopen the link before retrying after a connection error
};

struct TransportSpec {
  TransportKind kind = TransportKind::kModbusTcp;
  // Modbus TCP
  std::string host = "127.0.0.1";
  int port = 502;
  // Modbus RTU and serial
  std::string device;  // e.g. /dev/ttyUSB0; a program may override it (pseudo-terminals)
  int baud = 9600;
  char parity = 'N';  // 'N', 'E' or 'O'
  int data_bits = 8;
  int stop_bits = 1;
  // Modbus (TCP and RTU)
  int unit_id = 1;
  // Serial command sets
  std::string terminator = "\n";
  RetryPolicy retry;
};

// ---- Modbus register maps ---------------------------------------------------------------

enum class RegisterType { kU16, kI16, kU32, kI32, kF32 };
enum class RegisterBank { kHolding, kInput };
enum class WordOrder { kHighFirst, kLowFirst };  // which 16-bit half of a 32-bit value comes first

struct RegisterField {
  bool present = false;
  int address = 0;  // 0-based protocol address
  RegisterType type = RegisterType::kU16;
  RegisterBank bank = RegisterBank::kHolding;
  double lsb = 1.0;  // SI value of one raw count (for f32: of 1.0 in the register)
  int width() const { return (type == RegisterType::kU16 || type == RegisterType::kI16) ? 1 : 2; }
};

struct TableAxisRegisters {
  RegisterField mode;             // written: codes.mode_*
  RegisterField position_demand;  // written: angle for position mode (shortest way)
  RegisterField rate_demand;      // written: rate for rate mode
  RegisterField rotate_by;        // written: signed relative angle (explicit direction)
  RegisterField command;          // written: codes.cmd_*
  RegisterField position;         // read: current angle
  RegisterField rate;             // read: current rate
  RegisterField status;           // read: axis status bits
  // Optional (both or neither): the profile of the following position-mode commands.
  RegisterField rate_limit;   // written: rate of moves and rotations
  RegisterField accel_limit;  // written: their acceleration and braking
};

// Integer codes written to mode/command/control registers (and, for the serial command set,
// nothing: it uses words). Defaults are the codes of our reference map.
struct TableCodes {
  int mode_off = 0, mode_position = 1, mode_rate = 2;
  int cmd_move = 1, cmd_rotate = 2, cmd_stop = 3;
  int ctl_estop = 1, ctl_interlock_close = 2, ctl_interlock_open = 3, ctl_interlock_reset = 4;
};

// Bit numbers in the status words (global status register / serial status byte; axis status).
struct TableStatusBits {
  int interlock_closed = 0;
  int interlock_tripped = 1;
  int estop = 2;
  int fault = 3;
  int axis_moving = 0;
  int axis_in_position = 1;
};

struct TableRegisterMap {
  WordOrder word_order = WordOrder::kHighFirst;
  RegisterField status;   // read: global status bits
  RegisterField control;  // written: codes.ctl_*
  std::vector<TableAxisRegisters> axes;
};

// ---- Serial (SCPI-like) command sets ------------------------------------------------------

// A command template: "{axis}" becomes the axis number (axis_base-based), "{value}" the number
// in the command set's units. Queries answer one line with a number.
struct SerialCommand {
  std::string text;
  double timeout_s = 0.0;  // 0: the transport's retry.timeout_s
};

struct TableCommandSet {
  int axis_base = 1;        // number of the first axis in commands
  double angle_unit = 0.0;  // SI value of 1.0 in commands (deg -> pi/180)
  double rate_unit = 0.0;
  double accel_unit = 0.0;   // SI value of 1.0 in set_accel_limit (when given)
  std::string ack;           // reply to a setting command ("" = none expected)
  std::string error_prefix;  // a reply starting with this is a device-reported error
  SerialCommand mode_off, mode_position, mode_rate, demand_position, demand_rate, rotate, stop,
      estop, read_position, read_rate, read_status, read_axis_status, interlock_close,
      interlock_open, interlock_reset;
  // Optional (both or neither, text empty when absent): the profile of the following
  // position-mode commands, "{value}" in rate_unit / accel_unit.
  SerialCommand set_rate_limit, set_accel_limit;
};

// ---- Tables ---------------------------------------------------------------------------

struct TableLimits {
  double max_rate = 0.0;                          // rad/s
  double max_accel = 0.0;                         // rad/s^2
  double max_jerk = 0.0;                          // rad/s^3 (0: not limited)
  bool limited_travel = false;                    // false: continuous rotation
  double position_min = 0.0, position_max = 0.0;  // rad, when limited_travel
};

// The controller's host watchdog (communication-loss timeout): the host writes a changing
// value to the heartbeat register at every poll; when it has not changed for longer than
// timeout_s while armed (armed by the first change), the controller brakes every axis to
// rest and opens its interlock (docs/devices.md "Host watchdog"). Modbus only: the serial
// command sets we speak have no heartbeat command.
struct HostWatchdog {
  RegisterField heartbeat;  // holding register, u16 or u32: a counter, one up per poll
  double timeout_s = 0.5;   // s, wall clock at the controller
  bool declared() const { return heartbeat.present; }
};

struct TableDeviceSpec {
  std::string file;
  std::string vendor, model;
  calib::TableKind kind = calib::TableKind::kTwoAxis;
  TransportSpec transport;
  TableLimits limits;
  TableCodes codes;
  TableStatusBits bits;
  TableRegisterMap registers;  // Modbus transports
  TableCommandSet commands;    // serial transport
  HostWatchdog watchdog;       // not declared: the controller keeps going when the host dies
  int axisCount() const { return calib::axisCount(kind); }
  std::string name() const { return vendor + " " + model; }
  // The device file says how to set each axis' rate and acceleration profile (else the
  // controller moves at its own fixed profile, whatever a plan asks).
  bool profileSettable() const;
};

// ---- Thermal chambers -----------------------------------------------------------------

struct ChamberRegisterMap {
  WordOrder word_order = WordOrder::kHighFirst;
  RegisterField setpoint;     // read/written, degC
  RegisterField temperature;  // read: process value, degC
  RegisterField ramp_rate;    // read/written, degC/s (0: step)
  RegisterField run;          // written/read: codes run/stop
  RegisterField alarms;       // read: alarm bits
};

struct ChamberCodes {
  int run = 1, stop = 0;
};

struct ChamberAlarmBits {
  int high = 0;    // process value above the high limit
  int low = 1;     // below the low limit
  int sensor = 2;  // sensor break
};

struct ChamberDeviceSpec {
  std::string file;
  std::string vendor, model;
  std::string based_on;  // documentation the register map follows
  TransportSpec transport;
  double temp_min_c = -40.0, temp_max_c = 85.0;
  double max_ramp = 0.0;           // degC/s
  double time_constant_s = 120.0;  // first-order response (used by the virtual chamber)
  ChamberRegisterMap registers;
  ChamberCodes codes;
  ChamberAlarmBits alarm_bits;
  std::string name() const { return vendor + " " + model; }
};

// Parsing from text (file name only used in diagnostics) and from a file.
std::optional<TableDeviceSpec> parseTableDevice(std::string_view text, io::Diagnostics& diag);
std::optional<TableDeviceSpec> loadTableDevice(const std::string& path, io::Diagnostics& diag);
std::optional<ChamberDeviceSpec> parseChamberDevice(std::string_view text, io::Diagnostics& diag);
std::optional<ChamberDeviceSpec> loadChamberDevice(const std::string& path, io::Diagnostics& diag);

}  // namespace imubench::drivers
