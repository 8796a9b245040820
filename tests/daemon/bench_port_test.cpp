// The plan runner driving the virtual table and chamber over Modbus TCP through the real
// drivers (DriverBenchPort): the 12-run plan to the end, pause/resume in a rotation, an
// interlock trip raised as a table fault. No IMU here (the observation says it is alive).
#include "daemon/bench_port.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>

#include "nav/rotation.h"
#include "tests/daemon/library_plan_steps.h"
#include "tests/drivers/virtual_bench_fixture.h"

namespace imubench::daemon {
namespace {

namespace dt = drivers::testing;

double wallNow() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::vector<RunStep> twelveRunSteps() {
  return testing::libraryPlanSteps("two_axis_12run.toml");
}

// The virtual world runs 200x faster than the wall clock, so plan holds (plan seconds) are
// scaled down for the runner's wall-clock timing; motions run at the controller's own speed.
constexpr double kScale = 200.0;

class RunnerOverModbus : public ::testing::Test {
 protected:
  void SetUp() override {
    table_spec_ = dt::tableSpec("imubench-ref-2axis-tcp.toml");
    chamber_spec_ = dt::chamberSpec("watlow-f4-style.toml");
    world_ = std::make_unique<drivers::VirtualWorld>(table_spec_, chamber_spec_, kScale);
    // A stalled test machine must not open the interlock through the host watchdog in a test
    // about something else (LateReplies... sets the device file's 0.5 s again).
    setWatchdogTimeout(5.0);
    table_regs_ =
        std::make_unique<drivers::VirtualTableRegisters>(*world_, table_spec_, log_.sink());
    chamber_regs_ =
        std::make_unique<drivers::VirtualChamberRegisters>(*world_, chamber_spec_, log_.sink());
    table_server_ = std::make_unique<drivers::ModbusServer>(*table_regs_, faults_, log_.sink());
    chamber_server_ = std::make_unique<drivers::ModbusServer>(*chamber_regs_, faults_, log_.sink());
    ASSERT_TRUE(table_server_->startTcp("127.0.0.1", 0).ok);
    ASSERT_TRUE(chamber_server_->startTcp("127.0.0.1", 0).ok);
    table_spec_.transport.port = table_server_->port();
    chamber_spec_.transport.port = chamber_server_->port();
    table_ = drivers::makeTableDriver(table_spec_, log_.sink());
    chamber_ = drivers::makeChamberDriver(chamber_spec_, log_.sink());
    port_ = std::make_unique<DriverBenchPort>(*table_, chamber_.get());
    steps_ = twelveRunSteps();
    for (auto& s : steps_) s.planned_s /= kScale;
    RunnerOptions o;
    o.chamber_safe_setpoint_c = 23.0;
    o.chamber_over_temperature_c = 90.0;
    runner_ = std::make_unique<PlanRunner>(steps_, o, *port_);
  }

  // The controller's host-watchdog timeout, wall seconds.
  void setWatchdogTimeout(double wall_s) {
    world_->withTable([wall_s](drivers::VirtualTable& t, double) {
      t.setWatchdogTimeout(wall_s * kScale);
      return 0;
    });
  }
  // One daemon poll: observe, tick, collect events.
  void poll() {
    const double now = wallNow();
    runner_->tick(port_->observe(now, now));
    for (auto& e : runner_->takeEvents()) events_.push_back(std::move(e));
  }
  bool pollUntil(const std::function<bool()>& cond, double limit_s) {
    return dt::waitUntil(
        [&] {
          poll();
          return cond();
        },
        limit_s);
  }
  std::string alarms() const {
    std::string s;
    for (const auto& e : events_) {
      if (e.kind == RunnerEvent::Kind::kAlarm) s += e.message + "\n";
    }
    return s;
  }

  dt::EventLog log_;
  drivers::LinkFaults faults_;
  drivers::TableDeviceSpec table_spec_;
  drivers::ChamberDeviceSpec chamber_spec_;
  std::unique_ptr<drivers::VirtualWorld> world_;
  std::unique_ptr<drivers::VirtualTableRegisters> table_regs_;
  std::unique_ptr<drivers::VirtualChamberRegisters> chamber_regs_;
  std::unique_ptr<drivers::ModbusServer> table_server_, chamber_server_;
  std::unique_ptr<drivers::TableDriver> table_;
  std::unique_ptr<drivers::ChamberDriver> chamber_;
  std::unique_ptr<DriverBenchPort> port_;
  std::vector<RunStep> steps_;
  std::unique_ptr<PlanRunner> runner_;
  std::vector<RunnerEvent> events_;
};

TEST_F(RunnerOverModbus, TwelveRunPlanToTheEnd) {
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->state() == RunnerState::kFinished; }, 120.0))
      << runnerStateName(runner_->state()) << " at step " << runner_->currentStep() << "\n"
      << alarms() << log_.all();
  EXPECT_EQ(runner_->exit(), RunExit::kCompleted);
  EXPECT_EQ(alarms(), "");
  // What the virtual table executed: every rotation of the plan, in its direction.
  const calib::Motion m = world_->withMotion([](const calib::Motion& mm, double) { return mm; });
  for (int a = 0; a < 2; ++a) {
    const double end = m.axes[static_cast<std::size_t>(a)].at(m.duration).angle;
    EXPECT_NEAR(
        std::remainder(end - steps_.back().end_angles[static_cast<std::size_t>(a)], 2.0 * kPi), 0.0,
        1e-4)
        << "axis " << a;
  }
}

// The table turns at the plan's rate and acceleration, not its controller's maximum: what the
// virtual table executed for run01_x_p1 (180 deg at 10 deg/s, 5 deg/s^2: 2 s ramps, 20 s).
TEST_F(RunnerOverModbus, RotationRunsAtThePlansRateAndAcceleration) {
  std::size_t run01 = 0;
  while (run01 < steps_.size() && steps_[run01].label != "run01_x_p1") ++run01;
  ASSERT_LT(run01, steps_.size());
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->currentStep() > static_cast<int>(run01); }, 60.0))
      << alarms();
  const calib::Motion m = world_->withMotion([](const calib::Motion& mm, double) { return mm; });
  double rate = 0.0, accel = 0.0, t_start = -1.0, t_end = -1.0;
  for (const calib::AxisPhase& p : m.axes[0].phases()) {
    rate = std::max(rate, std::abs(p.rate0));
    accel = std::max(accel, std::abs(p.accel));
    if (t_start < 0.0 && p.accel != 0.0) t_start = p.t0;
    if (t_start >= 0.0 && p.rate0 == 0.0 && p.accel == 0.0 && t_end < 0.0) t_end = p.t0;
  }
  EXPECT_NEAR(rate * kRadToDeg, 10.0, 1e-3);
  EXPECT_NEAR(accel * kRadToDeg, 5.0, 1e-3);
  EXPECT_NEAR(t_end - t_start, 20.0, 1e-3);
  EXPECT_EQ(alarms(), "");
}

TEST_F(RunnerOverModbus, PauseInARotationStopsTheTableAndResumeFinishesThePlan) {
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil(
      [&] {
        const int k = runner_->currentStep();
        return k >= 0 && k < static_cast<int>(steps_.size()) &&
               steps_[static_cast<std::size_t>(k)].kind == calib::SegmentKind::kRotate &&
               port_->lastReading().axes.size() == 2 &&
               (port_->lastReading().axes[0].moving || port_->lastReading().axes[1].moving);
      },
      60.0));
  ASSERT_TRUE(runner_->pause(wallNow()).ok);
  // The table comes to rest and stays there while paused.
  ASSERT_TRUE(pollUntil(
      [&] {
        const auto& r = port_->lastReading();
        return !r.axes[0].moving && !r.axes[1].moving;
      },
      30.0));
  EXPECT_EQ(runner_->state(), RunnerState::kPaused);
  ASSERT_TRUE(runner_->resume(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->state() == RunnerState::kFinished; }, 120.0))
      << alarms();
  EXPECT_EQ(runner_->exit(), RunExit::kCompleted);
}

TEST_F(RunnerOverModbus, InterlockTripIsATableFaultThatPausesTheRun) {
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->currentStep() >= 2; }, 60.0));
  world_->withTable([](drivers::VirtualTable& t, double now) { t.trip(now, "door opened"); });
  ASSERT_TRUE(pollUntil([&] { return runner_->state() == RunnerState::kPaused; }, 30.0));
  EXPECT_NE(alarms().find("table fault"), std::string::npos) << alarms();
  const Status r = runner_->resume(wallNow());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("fault"), std::string::npos) << r.message;
}

TEST_F(RunnerOverModbus, TableControllerGoneStopsThePlanWithAnAlarm) {
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->currentStep() >= 2; }, 60.0));
  table_server_->stop();  // the controller's process dies: connection refused from now on
  ASSERT_TRUE(pollUntil([&] { return runner_->state() == RunnerState::kPaused; }, 60.0))
      << runnerStateName(runner_->state());
  // Either a command of the next step fails, naming the driver's reason, or the poll finds
  // the table silent past the timeout: both stop the plan with the reason in the alarm.
  const std::string a = alarms();
  EXPECT_TRUE(a.find("Connection refused") != std::string::npos ||
              a.find("table not answering") != std::string::npos)
      << a;
  EXPECT_FALSE(port_->lastTableError().empty());
  EXPECT_FALSE(runner_->resume(wallNow()).ok);
}

// Replies later than the table's 300 ms reply timeout: no call of the port blocks longer than
// about one reply timeout (a polling read makes one attempt; after kSilentReads unanswered
// reads the table's commands too, and it is read only once per kSilentRetryPeriodS); the run
// pauses with an alarm, and once the replies are on time the table is read every poll again.
// Heartbeats 0.6 s apart let the controller's host watchdog (0.5 s) open its interlock: the
// operator re-arms (prepare) before resuming.
TEST_F(RunnerOverModbus, LateRepliesBlockEachCallForOneReplyTimeoutAtMost) {
  setWatchdogTimeout(table_spec_.watchdog.timeout_s);
  ASSERT_TRUE(runner_->start(wallNow()).ok);
  ASSERT_TRUE(pollUntil([&] { return runner_->currentStep() >= 1; }, 60.0));
  faults_.reply_delay_s = 0.6;
  double slowest = 0.0;
  int reads_skipped = 0;
  const double end = wallNow() + 4.0;
  while (wallNow() < end) {
    const double t0 = wallNow();
    const BenchObservation o = port_->observe(t0, t0);
    runner_->tick(o);
    for (auto& e : runner_->takeEvents()) events_.push_back(std::move(e));
    const double took = wallNow() - t0;
    slowest = std::max(slowest, took);
    reads_skipped += !o.table_ok && took < 0.05 ? 1 : 0;
  }
  EXPECT_EQ(runner_->state(), RunnerState::kPaused);
  EXPECT_NE(alarms().find("table not answering"), std::string::npos) << alarms();
  // One attempt of 300 ms (plus the stop commands of the alarm, one attempt each).
  EXPECT_LT(slowest, 0.3 * 2 + 0.35) << "a call blocked for " << slowest << " s";
  EXPECT_GT(reads_skipped, 10) << "a silent table is not read on every poll";
  EXPECT_FALSE(runner_->resume(wallNow()).ok);
  faults_.reply_delay_s = 0.0;
  EXPECT_GE(
      world_->withTable([](drivers::VirtualTable& t, double) { return t.watchdogExpiries(); }), 1);
  ASSERT_TRUE(pollUntil([&] { return port_->prepare().ok; }, 30.0)) << log_.all();
  ASSERT_TRUE(pollUntil([&] { return runner_->resume(wallNow()).ok; }, 30.0)) << alarms();
  ASSERT_TRUE(pollUntil([&] { return runner_->state() == RunnerState::kFinished; }, 120.0))
      << alarms();
  EXPECT_EQ(runner_->exit(), RunExit::kCompleted);
}

}  // namespace
}  // namespace imubench::daemon
