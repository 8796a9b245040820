#include "daemon/bench_port.h"

#include <chrono>

namespace imubench::daemon {

namespace {

double steadyNowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// After a polling read: counts the unanswered ones in a row; a silent device makes one
// attempt per command and waits kSilentRetryPeriodS before its next read.
template <class Driver>
void afterPollingRead(bool answered, Driver* driver, int* reads, double* retry_at_s) {
  *reads = answered ? 0 : *reads + 1;
  const bool silent = *reads >= DriverBenchPort::kSilentReads;
  driver->setSingleAttempt(silent);
  if (silent) *retry_at_s = steadyNowS() + DriverBenchPort::kSilentRetryPeriodS;
}

// Adds the wall time of its scope to *total (DriverBenchPort::busyS).
class BusyTime {
 public:
  explicit BusyTime(double* total) : total_(total), t0_(steadyNowS()) {}
  ~BusyTime() { *total_ += steadyNowS() - t0_; }
  BusyTime(const BusyTime&) = delete;
  BusyTime& operator=(const BusyTime&) = delete;

 private:
  double* total_;
  double t0_;
};

}  // namespace

DriverBenchPort::DriverBenchPort(drivers::TableDriver& table, drivers::ChamberDriver* chamber)
    : table_(table),
      chamber_(chamber),
      modes_(static_cast<std::size_t>(table.spec().axisCount())) {}

// The controller may have been switched by someone else (its front panel, a stop): the mode
// is set whenever we have not set it ourselves since the last stop.
Status DriverBenchPort::positionMode(int axis) {
  auto& mode = modes_.at(static_cast<std::size_t>(axis));
  if (mode == drivers::AxisMode::kPosition) return {};
  Status st = table_.setMode(axis, drivers::AxisMode::kPosition);
  if (st.ok) mode = drivers::AxisMode::kPosition;
  return st;
}

Status DriverBenchPort::prepare() {
  const BusyTime busy(&busy_s_);
  if (table_.state() == drivers::DeviceState::kOffline) {
    if (auto st = table_.connect(); !st.ok) return st;
  }
  if (chamber_ != nullptr && chamber_->state() == drivers::DeviceState::kOffline) {
    if (auto st = chamber_->connect(); !st.ok) return st;
  }
  for (auto& m : modes_) m.reset();
  // An operator's start or re-arm: the device file's whole retry chain.
  table_.setSingleAttempt(false);
  if (chamber_ != nullptr) chamber_->setSingleAttempt(false);
  if (auto st = table_.interlock(drivers::InterlockCommand::kClose); !st.ok) return st;
  // An emergency stop or a trip stays until someone resets it at the bench on purpose: a
  // plan does not start on a table that is not cleared.
  drivers::TableReading& r = reading_;
  r = drivers::TableReading{};
  const Status st = table_.read(&r);
  table_error_ = st.ok ? std::string() : st.message;
  // It answered: read at every poll again from now on (a silent table read once a second
  // would feed the controller's host watchdog too seldom and open the interlock just closed).
  if (st.ok) table_silence_ = Silence{};
  if (r.estop || r.interlock_tripped || r.fault) {
    return Status::Error("the table reports " + (st.ok ? std::string("a fault") : st.message) +
                         ": clear it at the controller before starting");
  }
  return st;
}

Status DriverBenchPort::moveTo(int axis, double angle_rad, const drivers::MotionLimits& limits) {
  const BusyTime busy(&busy_s_);
  if (auto st = positionMode(axis); !st.ok) return st;
  if (auto st = table_.setProfile(axis, limits); !st.ok) return st;
  return table_.moveTo(axis, angle_rad);
}

Status DriverBenchPort::rotateBy(int axis, double delta_rad, const drivers::MotionLimits& limits) {
  const BusyTime busy(&busy_s_);
  if (auto st = positionMode(axis); !st.ok) return st;
  if (auto st = table_.setProfile(axis, limits); !st.ok) return st;
  return table_.rotateBy(axis, delta_rad);
}

Status DriverBenchPort::stopAll() {
  const BusyTime busy(&busy_s_);
  Status first;
  for (int a = 0; a < table_.spec().axisCount(); ++a) {
    const Status st = table_.stop(a);
    modes_[static_cast<std::size_t>(a)].reset();
    if (!st.ok && first.ok) first = st;  // stop every axis even when one fails
  }
  return first;
}

Status DriverBenchPort::emergencyStop() {
  const BusyTime busy(&busy_s_);
  for (auto& m : modes_) m.reset();
  return table_.emergencyStop();
}

Status DriverBenchPort::chamberSetpoint(double setpoint_c, double ramp_c_per_s) {
  const BusyTime busy(&busy_s_);
  if (chamber_ == nullptr) return {};
  if (ramp_c_per_s > 0.0) {
    if (auto st = chamber_->setRampRate(ramp_c_per_s); !st.ok) return st;
  }
  if (auto st = chamber_->setSetpoint(setpoint_c); !st.ok) return st;
  return chamber_->run(true);
}

BenchObservation DriverBenchPort::observe(double now_s, double imu_last_frame_s) {
  BenchObservation o;
  o.now_s = now_s;
  o.imu_last_frame_s = imu_last_frame_s;
  o.table_last_ok_s = table_last_ok_s_;
  o.chamber_temp_c = chamber_temp_c_;
  o.busy_s = busy_s_;
  if (steadyNowS() < table_silence_.retry_at_s) return o;  // silent: next attempt later
  reading_ = drivers::TableReading{};
  table_.setSingleAttempt(true);  // a polling read: the next poll is its retry
  const Status st = table_.read(&reading_);
  table_error_ = st.ok ? std::string() : st.message;
  // A controller that reports a tripped interlock, an emergency stop or a fault answered:
  // that is a fault to raise now, not a silence to wait out.
  const bool answered_fault = reading_.interlock_tripped || reading_.estop || reading_.fault;
  afterPollingRead(st.ok || answered_fault, &table_, &table_silence_.reads,
                   &table_silence_.retry_at_s);
  o.table_ok = st.ok || answered_fault;
  if (answered_fault) o.table_fault = st.ok ? "controller reports a fault" : st.message;
  if (st.ok) o.interlock_closed = reading_.interlock_closed;
  if (o.table_ok) table_last_ok_s_ = now_s;
  o.table_last_ok_s = table_last_ok_s_;
  for (const auto& a : reading_.axes) {
    o.angles.push_back(a.angle);
    o.rates.push_back(a.rate);
    o.angles_unix_s.push_back(a.read_unix_s);
    o.angles_round_trip_s.push_back(a.round_trip_s);
    o.moving = o.moving || a.moving;
  }
  return o;
}

bool DriverBenchPort::readChamber(drivers::ChamberReading* out) {
  const BusyTime busy(&busy_s_);
  chamber_temp_c_.reset();
  if (chamber_ == nullptr || steadyNowS() < chamber_silence_.retry_at_s) return false;
  *out = drivers::ChamberReading{};
  chamber_->setSingleAttempt(true);  // a polling read: the next poll is its retry
  // An alarm still fills the reading; a communication error does not.
  const Status st = chamber_->read(out);
  const bool answered = st.ok || out->alarms_raw != 0;
  afterPollingRead(answered, chamber_, &chamber_silence_.reads, &chamber_silence_.retry_at_s);
  if (!answered) return false;
  chamber_temp_c_ = out->temperature_c;
  return true;
}

}  // namespace imubench::daemon
