// Turntable drivers behind one small interface (like chrony's refclock driver table): a
// two- or three-axis table in position, rate or off mode. Implementations: Modbus TCP/RTU
// (table_modbus) and an SCPI-like serial command set (table_serial); which one, and every
// address, register and command, comes from the device file.
//
// Angles are table angles in rad, rates rad/s, axis index in calib::Motion's order.
// Every call returns a Status the caller checks; state() says what the driver is in.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "drivers/device_errors.h"
#include "drivers/device_file.h"

namespace imubench::drivers {

enum class AxisMode { kOff, kPosition, kRate };
enum class InterlockCommand { kClose, kOpen, kReset };
const char* axisModeName(AxisMode m);

struct TableAxisReading {
  double angle = 0.0;  // rad, as the controller reports it (wrapped to (-pi, pi] by most)
  double rate = 0.0;   // rad/s
  // When the controller sampled `angle`: the midpoint of the request and reply that read it
  // (unixTimeS); 0 when unknown. Each axis is read by its own request, so the axes' instants
  // differ by a round trip or more.
  double read_unix_s = 0.0;
  // That request's round trip (reply time minus request time), s; 0 when unknown. The stamp
  // read_unix_s is within half of it of the controller's sampling instant.
  double round_trip_s = 0.0;
  bool moving = false;
  bool in_position = false;
};

// The motion profile of one position-mode command: the controller accelerates at `accel` up
// to `rate` and brakes at `accel` (rad/s, rad/s^2, both > 0). The plan's expansion computed
// the step's profile with exactly these values, so the table does what the plan says.
struct MotionLimits {
  double rate = 0.0;
  double accel = 0.0;
};

struct TableReading {
  std::vector<TableAxisReading> axes;
  uint32_t status_raw = 0;
  bool interlock_closed = false;
  bool interlock_tripped = false;
  bool estop = false;
  bool fault = false;
};

class TableDriver {
 public:
  virtual ~TableDriver() = default;
  virtual Status connect() = 0;
  virtual Status setMode(int axis, AxisMode mode) = 0;
  // The rate and acceleration of the axis' following moveTo/rotateBy (and its braking). A
  // device file without the registers/commands to set them cannot obey: an error, never a
  // silently faster motion. Limits above the spec's limits are refused.
  virtual Status setProfile(int axis, const MotionLimits& limits) = 0;
  // Position mode: go to `angle`; the controller takes the shortest way.
  virtual Status moveTo(int axis, double angle) = 0;
  // Position mode: turn by `delta` (its sign is the direction; +pi and -pi differ).
  virtual Status rotateBy(int axis, double delta) = 0;
  // Rate mode: run at `rate`.
  virtual Status setRate(int axis, double rate) = 0;
  virtual Status stop(int axis) = 0;
  virtual Status emergencyStop() = 0;
  virtual Status interlock(InterlockCommand c) = 0;
  // Reads angles, rates and status bits. An open/tripped interlock or a controller fault
  // puts the driver in kFault and returns an error naming the reason (the reading is filled).
  // With a host watchdog in the device file (TableDeviceSpec::watchdog) every read first
  // writes the next heartbeat: whoever polls the table keeps the controller's watchdog fed
  // (and arms it with the first read after connecting or re-arming); a failed heartbeat
  // write fails the read.
  virtual Status read(TableReading* out) = 0;
  virtual DeviceState state() const = 0;
  virtual const TableDeviceSpec& spec() const = 0;
  // On: each request gets one attempt instead of the device file's retry chain. For a caller
  // that polls a device which stopped answering: the next poll is the retry, and no call
  // blocks longer than one reply timeout. Off (the default) when it answers again.
  virtual void setSingleAttempt(bool on) = 0;
};

// Makes the driver the device file's transport asks for (not yet connected;
// drivers/table_factory.cpp, the one file that knows both implementations).
std::unique_ptr<TableDriver> makeTableDriver(const TableDeviceSpec& spec, EventSink sink);

// Shared argument checks (axis index, limits) used by every implementation.
Status checkTableAxis(const TableDeviceSpec& spec, int axis);
Status checkTableRate(const TableDeviceSpec& spec, double rate);
Status checkTableTarget(const TableDeviceSpec& spec, double angle);
// A profile the device file can set (TableDeviceSpec::profileSettable) within the spec's limits.
Status checkTableProfile(const TableDeviceSpec& spec, const MotionLimits& limits);
// Whether the controller's status word `raw` allows motion: an error "motion refused: ..."
// naming its fault (then sent to `sink` and latched in *status_fault) or the open interlock.
Status checkTableMotion(const TableDeviceSpec& spec, uint32_t raw, const EventSink& sink,
                        bool* status_fault);
// Fills the global flags of r from the status word; returns the reason when it is a fault.
std::string decodeTableStatus(const TableStatusBits& bits, uint32_t raw, TableReading* r);

}  // namespace imubench::drivers
