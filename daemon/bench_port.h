// The plan runner's BenchPort over the real drivers: the table (position mode for moves and
// rotations at the step's rate/acceleration profile, stop, emergency stop) and the optional chamber
// (setpoint). Also turns driver readings into the runner's BenchObservation. Owns no device: the
// daemon does.
#pragma once

#include <optional>
#include <vector>

#include "daemon/plan_runner.h"
#include "drivers/chamber.h"
#include "drivers/table.h"

namespace imubench::daemon {

class DriverBenchPort : public BenchPort {
 public:
  // chamber may be null (a bench without a chamber); the references must outlive the port.
  DriverBenchPort(drivers::TableDriver& table, drivers::ChamberDriver* chamber);

  // Connects if needed and closes the interlock (motion needs it closed); refuses a table in
  // emergency stop, tripped or faulted (cleared at the controller on purpose, never by us).
  // Also the operator's re-arm after a controller restart. Updates lastReading().
  Status prepare() override;
  // Each motion sets the axis' profile first (the controller keeps the last one it was given).
  Status moveTo(int axis, double angle_rad, const drivers::MotionLimits& limits) override;
  Status rotateBy(int axis, double delta_rad, const drivers::MotionLimits& limits) override;
  Status stopAll() override;
  Status emergencyStop() override;
  Status chamberSetpoint(double setpoint_c, double ramp_c_per_s) override;

  // A device that does not answer would block its caller for the device file's whole retry
  // chain (timeout x attempts) on every call. The polling reads make one attempt each (the
  // next poll is the retry; comm_timeout judges silence). After kSilentReads unanswered reads
  // in a row the device counts as silent: commands get one attempt too (setSingleAttempt;
  // the retry chain again once it answers), and it is read again only kSilentRetryPeriodS
  // after each read ended (wall time, measured here). So no call blocks the daemon's loop
  // longer than one reply timeout, and the loop stays free between the attempts to find a
  // silent device back (status, IMU recording); a single lost reply changes nothing.
  static constexpr int kSilentReads = 3;
  static constexpr double kSilentRetryPeriodS = 1.0;

  // Reads the table and fills what the runner needs, with the chamber temperature of the
  // last readChamber(). now_s: the daemon's monotonic time; imu_last_frame_s: when the IMU
  // last delivered a sample (same clock). BenchObservation::busy_s is busyS() then. The last driver
  // errors are kept for the alarm text (lastTableError()). A silent table is not read again before
  // kSilentRetryPeriodS has passed (table_ok false meanwhile).
  BenchObservation observe(double now_s, double imu_last_frame_s);
  // Reads the chamber (the daemon does on the chamber's own, slower timer). True when *out
  // holds a temperature: also with an active alarm (over-temperature is the runner's to
  // judge), not after a communication error (the driver's sink has it), nor while a silent
  // chamber waits for its next attempt (kSilentRetryPeriodS). No chamber: false.
  bool readChamber(drivers::ChamberReading* out);
  const drivers::TableReading& lastReading() const { return reading_; }
  // Seconds (monotonic, summed since construction) this port spent in device transactions
  // other than the table's polling reads: commands, the chamber's reads. The loop reads no
  // table meanwhile, by design: the daemon's judge of a gap in the table readings leaves this
  // time out (BenchConfig::table_reading_gap_s).
  double busyS() const { return busy_s_; }
  const std::string& lastTableError() const { return table_error_; }

 private:
  Status positionMode(int axis);

  drivers::TableDriver& table_;
  drivers::ChamberDriver* chamber_;
  std::vector<std::optional<drivers::AxisMode>> modes_;  // what we last set, per axis
  drivers::TableReading reading_;
  std::string table_error_;
  double table_last_ok_s_ = 0.0;
  // Unanswered polling reads in a row, and the steady-clock seconds before which a silent
  // device is not read again.
  struct Silence {
    int reads = 0;
    double retry_at_s = 0.0;
  };
  Silence table_silence_, chamber_silence_;
  std::optional<double> chamber_temp_c_;  // the last chamber read's, none after a failed one
  double busy_s_ = 0.0;                   // busyS()
};

}  // namespace imubench::daemon
