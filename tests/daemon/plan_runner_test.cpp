#include "daemon/plan_runner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "calib/model/thermal_lag.h"
#include "nav/rotation.h"
#include "tests/daemon/library_plan_steps.h"

namespace imubench::daemon {
namespace {

// A table that turns every commanded axis at a constant rate (no ramps: a controller that
// differs from the plan's profile), reports wrapped angles, and can go silent or get stuck.
class FakeBench : public BenchPort {
 public:
  explicit FakeBench(int axes) : angle_(axes, 0.0), target_(axes, 0.0) {}

  Status prepare() override {
    ++prepares;
    return {};
  }
  Status moveTo(int axis, double angle, const drivers::MotionLimits& l) override {
    log.push_back("move " + std::to_string(axis));
    profiles.push_back(l);
    if (fail_commands) return Status::Error("injected: no reply");
    target_[axis] = angle_[axis] + std::remainder(angle - angle_[axis], 2.0 * kPi);
    return {};
  }
  Status rotateBy(int axis, double delta, const drivers::MotionLimits& l) override {
    log.push_back("rotate " + std::to_string(axis));
    profiles.push_back(l);
    rotated.push_back(delta);
    if (fail_commands) return Status::Error("injected: no reply");
    if (!stuck) target_[axis] = angle_[axis] + delta;
    return {};
  }
  Status stopAll() override {
    ++stops;
    target_ = angle_;
    return {};
  }
  Status emergencyStop() override {
    ++estops;
    target_ = angle_;
    return {};
  }
  Status chamberSetpoint(double c, double ramp_c_per_s) override {
    ramps.push_back(ramp_c_per_s);
    setpoints.push_back(c);
    return {};
  }

  // Advances the physics by dt and returns what the daemon would observe at `now`.
  BenchObservation step(double now, double dt) {
    bool moving = false;
    for (std::size_t a = 0; a < angle_.size(); ++a) {
      const double d = target_[a] - angle_[a];
      const double max_step = rate * dt;
      angle_[a] += std::clamp(d, -max_step, max_step);
      moving = moving || std::abs(target_[a] - angle_[a]) > 0.0;
    }
    BenchObservation o;
    o.now_s = now;
    o.table_ok = !table_silent;
    if (!table_silent) table_last_ok = now;
    o.table_last_ok_s = table_last_ok;
    if (!imu_silent) imu_last = now;
    o.imu_last_frame_s = imu_last;
    for (double a : angle_) o.angles.push_back(std::remainder(a, 2.0 * kPi));
    o.moving = moving;
    o.chamber_temp_c = chamber_temp;
    o.interlock_closed = !interlock_open;
    return o;
  }
  double angle(int axis) const { return angle_[axis]; }

  double rate = 20.0 * kDegToRad;  // rad/s
  bool table_silent = false, imu_silent = false, stuck = false, fail_commands = false;
  bool interlock_open = false;  // the controller restarted: interlock open, no fault bit
  double table_last_ok = 0.0, imu_last = 0.0;
  double chamber_temp = 22.0;
  int stops = 0, estops = 0, prepares = 0;
  std::vector<std::string> log;
  std::vector<double> rotated, setpoints, ramps;
  std::vector<drivers::MotionLimits> profiles;  // with every moveTo/rotateBy, in order

 private:
  std::vector<double> angle_, target_;
};

std::vector<RunStep> twelveRunSteps() {
  return testing::libraryPlanSteps("two_axis_12run.toml");
}

RunnerOptions options() {
  RunnerOptions o;
  o.chamber_safe_setpoint_c = 23.0;
  o.chamber_over_temperature_c = 90.0;
  return o;
}

struct Harness {
  std::vector<RunStep> steps = twelveRunSteps();
  FakeBench bench{2};
  PlanRunner runner{steps, options(), bench};
  double now = 0.0;
  std::vector<RunnerEvent> events;
  static constexpr double kDt = 0.05;  // the daemon's table poll period

  void tick() {
    now += kDt;
    runner.tick(bench.step(now, kDt));
    for (auto& e : runner.takeEvents()) events.push_back(std::move(e));
  }
  // Ticks until pred() or the time limit; returns pred().
  template <class Pred>
  bool until(Pred pred, double limit_s) {
    const double end = now + limit_s;
    while (!pred() && now < end) tick();
    return pred();
  }
  int count(RunnerEvent::Kind kind, int step = -2) const {
    int n = 0;
    for (const auto& e : events) n += (e.kind == kind && (step == -2 || e.step == step)) ? 1 : 0;
    return n;
  }
  std::string lastAlarm() const {
    for (auto it = events.rbegin(); it != events.rend(); ++it) {
      if (it->kind == RunnerEvent::Kind::kAlarm) return it->message;
    }
    return "";
  }
  bool finished() const { return runner.state() == RunnerState::kFinished; }
  // Ticks until the first rotation step is under way and half done.
  int midRotation() {
    int k = -1;
    until(
        [&] {
          k = runner.currentStep();
          if (k < 0 || k >= static_cast<int>(steps.size())) return false;
          const RunStep& s = steps[k];
          return s.kind == calib::SegmentKind::kRotate &&
                 std::abs(bench.angle(s.axis) - s.start_angles[s.axis]) > 0.5 * std::abs(s.delta);
        },
        4000.0);
    return k;
  }
};

TEST(PlanRunner, StepsAreThePlansSegments) {
  const auto steps = twelveRunSteps();
  int rotations = 0;
  for (const auto& s : steps) rotations += s.kind == calib::SegmentKind::kRotate ? 1 : 0;
  EXPECT_EQ(rotations, 12);  // the 12 runs (each a 180-degree turn; reversals are runs too)
  for (std::size_t k = 1; k < steps.size(); ++k) {
    for (std::size_t a = 0; a < 2; ++a) {
      EXPECT_NEAR(steps[k].start_angles[a], steps[k - 1].end_angles[a], 1e-12) << k;
    }
  }
}

TEST(PlanRunner, RunsTheTwelveRunPlanToTheEnd) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
  EXPECT_EQ(h.bench.prepares, 1);
  // The fake turns at the plan's cruise rate without ramps: a little faster than planned.
  EXPECT_GT(h.now, 0.8 * h.runner.plannedTotalS());
  EXPECT_LT(h.now, 1.2 * h.runner.plannedTotalS());
  std::cout << "12-run plan: " << h.steps.size() << " steps, planned " << h.runner.plannedTotalS()
            << " s, ran " << h.now << " s of fake time\n";
  EXPECT_DOUBLE_EQ(h.runner.progress(), 1.0);
  EXPECT_DOUBLE_EQ(h.runner.etaS(), 0.0);
  int rotations = 0;
  for (std::size_t k = 0; k < h.steps.size(); ++k) {
    EXPECT_EQ(h.count(RunnerEvent::Kind::kStepStarted, static_cast<int>(k)), 1) << k;
    EXPECT_EQ(h.count(RunnerEvent::Kind::kStepFinished, static_cast<int>(k)), 1) << k;
    if (h.steps[k].kind == calib::SegmentKind::kRotate) {
      ASSERT_LT(rotations, static_cast<int>(h.bench.rotated.size()));
      EXPECT_EQ(h.bench.rotated[rotations++], h.steps[k].delta) << "direction and size, step " << k;
    }
  }
  EXPECT_EQ(rotations, static_cast<int>(h.bench.rotated.size()));
  EXPECT_EQ(h.count(RunnerEvent::Kind::kAlarm), 0) << h.lastAlarm();
  for (int a = 0; a < 2; ++a) {
    EXPECT_NEAR(std::remainder(h.bench.angle(a) - h.steps.back().end_angles[a], 2.0 * kPi), 0.0,
                1e-9);
  }
}

TEST(PlanRunner, PauseMidRotationThenResumeRerunsTheStepFromItsStart) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  const int k = h.midRotation();
  ASSERT_GE(k, 0);
  const RunStep& s = h.steps[k];
  const std::size_t rotations_before = h.bench.rotated.size();
  ASSERT_TRUE(h.runner.pause(h.now).ok);
  EXPECT_EQ(h.runner.state(), RunnerState::kPaused);
  EXPECT_EQ(h.bench.stops, 1);
  const double held = h.bench.angle(s.axis);
  h.until([] { return false; }, 5.0);  // paused: holds, commands nothing
  EXPECT_EQ(h.bench.angle(s.axis), held);
  EXPECT_EQ(h.bench.rotated.size(), rotations_before);
  EXPECT_FALSE(h.runner.pause(h.now).ok);

  ASSERT_TRUE(h.runner.resume(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.runner.currentStep() > k; }, 600.0));
  // Back to the start (a move), then the whole rotation again, same signed angle.
  ASSERT_EQ(h.bench.rotated.size(), rotations_before + 1);
  EXPECT_EQ(h.bench.rotated.back(), s.delta);
  EXPECT_EQ(h.count(RunnerEvent::Kind::kStepStarted, k), 2);
  EXPECT_EQ(h.count(RunnerEvent::Kind::kStepFinished, k), 1);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
}

TEST(PlanRunner, AbortStopsMotionParksTheChamberAndClosesAsAborted) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  ASSERT_GE(h.midRotation(), 0);
  ASSERT_TRUE(h.runner.abort(h.now).ok);
  EXPECT_EQ(h.runner.state(), RunnerState::kAborting);
  EXPECT_EQ(h.bench.stops, 1);
  ASSERT_FALSE(h.bench.setpoints.empty());
  EXPECT_EQ(h.bench.setpoints.back(), 23.0);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 10.0));
  EXPECT_EQ(h.runner.exit(), RunExit::kAborted);
  EXPECT_FALSE(h.runner.resume(h.now).ok);
  EXPECT_FALSE(h.runner.start(h.now).ok);  // a runner runs one plan; the daemon makes a new one
}

TEST(PlanRunner, EmergencyStopWorksInEveryState) {
  for (int which = 0; which < 4; ++which) {
    Harness h;
    if (which >= 1) {
      ASSERT_TRUE(h.runner.start(h.now).ok);
      ASSERT_GE(h.midRotation(), 0);
    }
    if (which == 2) {
      ASSERT_TRUE(h.runner.pause(h.now).ok);
    }
    if (which == 3) {
      ASSERT_TRUE(h.runner.abort(h.now).ok);
    }
    h.runner.emergencyStop(h.now, "operator");
    h.tick();
    EXPECT_EQ(h.bench.estops, 1) << which;
    EXPECT_EQ(h.runner.state(), RunnerState::kFaulted) << which;
    EXPECT_EQ(h.runner.exit(), RunExit::kEmergencyStop) << which;
    EXPECT_NE(h.lastAlarm().find("emergency stop by operator"), std::string::npos);
    EXPECT_FALSE(h.runner.resume(h.now).ok);
  }
}

TEST(PlanRunner, SecondStartWhileBusyIsRefused) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  const Status again = h.runner.start(h.now);
  EXPECT_FALSE(again.ok);
  EXPECT_NE(again.message.find("busy"), std::string::npos) << again.message;
  EXPECT_EQ(h.runner.state(), RunnerState::kRunning);
}

TEST(PlanRunner, SilentTableStopsPausesAndAlarmsThenResumesWhenBack) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  ASSERT_GE(h.midRotation(), 0);
  h.bench.table_silent = true;
  const double lost_at = h.now;
  ASSERT_TRUE(h.until([&] { return h.runner.state() == RunnerState::kPaused; }, 5.0));
  EXPECT_GT(h.now - lost_at, options().comm_timeout_s);
  EXPECT_LT(h.now - lost_at, options().comm_timeout_s + 0.2);
  EXPECT_NE(h.lastAlarm().find("table not answering"), std::string::npos) << h.lastAlarm();
  EXPECT_GE(h.bench.stops, 1);
  EXPECT_FALSE(h.runner.resume(h.now).ok);  // still silent
  h.bench.table_silent = false;
  h.tick();
  ASSERT_TRUE(h.runner.resume(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
}

TEST(PlanRunner, SilentImuPausesAndAlarms) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  h.until([] { return false; }, 20.0);
  h.bench.imu_silent = true;
  ASSERT_TRUE(h.until([&] { return h.runner.state() == RunnerState::kPaused; }, 5.0));
  EXPECT_NE(h.lastAlarm().find("IMU silent"), std::string::npos) << h.lastAlarm();
  EXPECT_FALSE(h.runner.resume(h.now).ok);
}

TEST(PlanRunner, StuckTableIsOverdueAndPauses) {
  Harness h;
  h.bench.stuck = true;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.runner.state() == RunnerState::kPaused; }, 4000.0));
  EXPECT_NE(h.lastAlarm().find("motion not complete"), std::string::npos) << h.lastAlarm();
}

TEST(PlanRunner, ChamberOverTemperatureGoesToTheSafeSetpointAndPauses) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  h.until([] { return false; }, 10.0);
  h.bench.chamber_temp = 95.0;
  h.tick();
  EXPECT_EQ(h.runner.state(), RunnerState::kPaused);
  ASSERT_FALSE(h.bench.setpoints.empty());
  EXPECT_EQ(h.bench.setpoints.back(), 23.0);
  EXPECT_NE(h.lastAlarm().find("over temperature"), std::string::npos) << h.lastAlarm();
  // Resume is refused while it is still too hot, accepted once it is back below the limit.
  const Status hot = h.runner.resume(h.now);
  EXPECT_FALSE(hot.ok);
  EXPECT_NE(hot.message.find("over temperature"), std::string::npos) << hot.message;
  h.bench.chamber_temp = 30.0;
  h.tick();
  EXPECT_TRUE(h.runner.resume(h.now).ok);
}

// Crash resume: a run started at step k runs k..end, each once, the steps before never.
TEST(PlanRunner, StartAtAStepRunsOnlyTheStepsFromIt) {
  Harness h;
  const int first = 5;
  ASSERT_FALSE(h.runner.startAt(h.now, static_cast<int>(h.steps.size())).ok);
  ASSERT_TRUE(h.runner.startAt(h.now, first).ok);
  EXPECT_EQ(h.runner.currentStep(), first);
  EXPECT_GT(h.runner.progress(), 0.0);  // the steps before count as done
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
  for (int k = 0; k < static_cast<int>(h.steps.size()); ++k) {
    EXPECT_EQ(h.count(RunnerEvent::Kind::kStepStarted, k), k < first ? 0 : 1) << k;
    EXPECT_EQ(h.count(RunnerEvent::Kind::kStepFinished, k), k < first ? 0 : 1) << k;
  }
  EXPECT_EQ(h.count(RunnerEvent::Kind::kAlarm), 0) << h.lastAlarm();
}

// A controller restart opens the interlock without a fault: the run pauses with an alarm that
// says how to go on, resume is refused until the interlock is closed again (the daemon's
// rearm), and then the interrupted step re-runs and the plan completes.
TEST(PlanRunner, InterlockOpenedByAControllerRestartPausesUntilRearmed) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  h.until([] { return false; }, 70.0);
  ASSERT_EQ(h.runner.state(), RunnerState::kRunning);
  h.bench.interlock_open = true;
  h.tick();
  EXPECT_EQ(h.runner.state(), RunnerState::kPaused);
  EXPECT_NE(h.lastAlarm().find("interlock open"), std::string::npos) << h.lastAlarm();
  EXPECT_NE(h.lastAlarm().find("imubench rearm"), std::string::npos) << h.lastAlarm();
  h.tick();
  const Status refused = h.runner.resume(h.now);
  EXPECT_FALSE(refused.ok);
  EXPECT_NE(refused.message.find("re-arm"), std::string::npos) << refused.message;
  h.bench.interlock_open = false;  // re-armed
  h.tick();
  ASSERT_TRUE(h.runner.resume(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.runner.state() == RunnerState::kFinished; }, 4000.0));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
}

TEST(PlanRunner, FailedCommandAlarmsAndPauses) {
  Harness h;
  h.bench.fail_commands = true;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.runner.state() == RunnerState::kPaused; }, 4000.0));
  EXPECT_NE(h.lastAlarm().find("injected: no reply"), std::string::npos) << h.lastAlarm();
}

TEST(PlanRunner, HoldsRunOnThePlanClockWhenGiven) {
  RunStep hold;
  hold.kind = calib::SegmentKind::kStatic;
  hold.label = "hold";
  hold.planned_s = 10.0;
  hold.start_angles = hold.end_angles = {0.0, 0.0};
  FakeBench bench(2);
  PlanRunner runner({hold}, options(), bench);
  ASSERT_TRUE(runner.start(0.0).ok);
  double now = 0.0;
  while (runner.state() == RunnerState::kRunning && now < 20.0) {
    now += 0.05;
    BenchObservation o = bench.step(now, 0.05);
    o.plan_time_s = 100.0 + 10.0 * now;  // an IMU clock running 10x the wall clock
    runner.tick(o);
  }
  EXPECT_EQ(runner.exit(), RunExit::kCompleted);
  EXPECT_NEAR(now, 1.0, 0.11);  // 10 s of plan time
}

// Each step carries the rate and acceleration its expansion planned, per axis: a rotate step's
// own, a rate step's own, a move's axis limits; nothing for an axis at rest.
TEST(PlanRunner, StepsCarryThePlannedProfile) {
  const auto find = [](const std::vector<RunStep>& steps, const std::string& label) {
    for (const auto& s : steps) {
      if (s.label == label) return s;
    }
    ADD_FAILURE() << "no step " << label;
    return RunStep{};
  };
  const auto twelve = twelveRunSteps();
  const RunStep run01 = find(twelve, "run01_x_p1");  // outer, 180 deg at 10 deg/s, 5 deg/s^2
  ASSERT_EQ(run01.limits.size(), 2u);
  EXPECT_NEAR(run01.limits[0].rate * kRadToDeg, 10.0, 1e-9);
  EXPECT_NEAR(run01.limits[0].accel * kRadToDeg, 5.0, 1e-9);
  EXPECT_EQ(run01.limits[1].rate, 0.0);
  EXPECT_EQ(run01.limits[1].accel, 0.0);
  const RunStep place = find(twelve, "place_z_p1");  // a 90-degree outer move: [table] limits
  EXPECT_NEAR(place.limits[0].rate * kRadToDeg, 20.0, 1e-9);
  EXPECT_NEAR(place.limits[0].accel * kRadToDeg, 10.0, 1e-9);
  const auto direct = testing::libraryPlanSteps("direct_two_axis.toml");
  const RunStep rate = find(direct, "rate_z_up_pos");  // rate step, inner, 30 deg/s, 10 deg/s^2
  EXPECT_EQ(rate.kind, calib::SegmentKind::kRotate);
  EXPECT_NEAR(rate.limits[1].rate * kRadToDeg, 30.0, 1e-9);
  EXPECT_NEAR(rate.limits[1].accel * kRadToDeg, 10.0, 1e-9);
  EXPECT_EQ(rate.limits[0].rate, 0.0);
  const auto plan = planLimits(twelve);
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_NEAR(plan[1].rate * kRadToDeg, 20.0, 1e-9);
}

// The runner sends every motion with its step's profile, and a return to a step's start
// (after a pause) with the axis' fastest planned profile, never more.
TEST(PlanRunner, MotionCommandsCarryTheStepsProfile) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  const int k = h.midRotation();
  ASSERT_GE(k, 0);
  ASSERT_TRUE(h.runner.pause(h.now).ok);
  ASSERT_TRUE(h.runner.resume(h.now).ok);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  ASSERT_EQ(h.bench.profiles.size(), h.bench.log.size());
  const auto plan = planLimits(h.steps);
  std::size_t rotations = 0, moves = 0;
  for (std::size_t c = 0; c < h.bench.log.size(); ++c) {
    const int axis = std::stoi(h.bench.log[c].substr(h.bench.log[c].find(' ') + 1));
    const drivers::MotionLimits& got = h.bench.profiles[c];
    if (h.bench.log[c].rfind("rotate", 0) == 0) {
      ++rotations;
      EXPECT_NEAR(got.rate * kRadToDeg, 10.0, 1e-9) << c;
      EXPECT_NEAR(got.accel * kRadToDeg, 5.0, 1e-9) << c;
    } else {
      ++moves;
      EXPECT_GT(got.rate, 0.0) << c;
      EXPECT_LE(got.rate, plan[static_cast<std::size_t>(axis)].rate) << c;
      EXPECT_LE(got.accel, plan[static_cast<std::size_t>(axis)].accel) << c;
    }
  }
  EXPECT_EQ(rotations, 13u);  // 12 runs and the interrupted one again
  EXPECT_GT(moves, 0u);
}

// ---- auto soak (soak = "auto"): ends on the measured temperature rate, never waits forever ----

// A chamber plan with one auto soak and a hold, expanded with the chamber's and the IMU's lags.
std::vector<RunStep> autoSoakSteps(const calib::model::ThermalLag& lag,
                                   const std::string& max_soak) {
  const std::string text = R"([plan]
name = "soak"
[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
[chamber]
min_temp = "-40 degC"
max_temp = "70 degC"
max_ramp = "1 degC/min"
[[step]]
type = "chamber"
setpoint = "-20 degC"
soak = "auto"
settle_rate = "0.05 degC/min"
settle_hold = "10 min"
max_soak = ")" + max_soak + R"("
[[step]]
type = "hold"
duration = "1 min"
)";
  io::Diagnostics diag("soak.toml");
  auto plan = plans::parsePlan(text, "soak.toml", diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  plans::ExpandOptions o;
  o.thermal = lag;
  const auto ex = plans::expand(*plan, o);
  EXPECT_TRUE(ex.status.ok) << ex.status.message;
  return runSteps(ex.motion);
}

// The IMU temperature source of a scripted soak run.
enum class TempScript { kModel, kModelChamberOnly, kSinusoid, kNone };

struct SoakRun {
  double started = -1.0, finished = -1.0;  // plan clock of the soak's step_started / finished
  std::vector<RunnerEvent> events;
  std::vector<double> ramps;  // the ramp rates the runner commanded with its setpoints
  RunExit exit = RunExit::kNone;
  const RunnerEvent* find(RunnerEvent::Kind k) const {
    for (const auto& e : events) {
      if (e.kind == k) return &e;
    }
    return nullptr;
  }
};

// Runs the soak plan on a FakeBench whose chamber follows calib/model/thermal_lag.h from the
// moment the setpoint is commanded, at the ramp rate commanded with it (0: the chamber steps);
// observations every second of plan time (the IMU clock runs 20x the wall clock), the IMU
// temperature quantised to 0.01 degC as a real sensor reports it.
SoakRun runSoak(const std::vector<RunStep>& steps, const calib::model::ThermalLag& lag,
                TempScript script) {
  FakeBench bench(2);
  PlanRunner runner(steps, options(), bench);
  SoakRun out;
  EXPECT_TRUE(runner.start(0.0).ok);
  double ramp = 0.0;
  calib::model::ThermalState cmd_state = calib::model::thermalAtRest(20.0);
  double t_cmd = 0.0, goal = 20.0;
  std::size_t seen_setpoints = 0;
  double t = 0.0;
  while (runner.state() == RunnerState::kRunning && t < 10 * 3600.0) {
    t += 1.0;
    const double wall = t / 20.0;
    if (bench.setpoints.size() != seen_setpoints) {
      cmd_state = calib::model::advanceThermal(cmd_state, goal, ramp, lag, t - t_cmd);
      t_cmd = t;
      goal = bench.setpoints.back();
      ramp = bench.ramps.back() > 0.0 ? bench.ramps.back() : 1e6;  // 0: a step
      seen_setpoints = bench.setpoints.size();
    }
    const auto th = calib::model::advanceThermal(cmd_state, goal, ramp, lag, t - t_cmd);
    BenchObservation o = bench.step(wall, 0.05);
    o.plan_time_s = t;
    o.chamber_temp_c = th.air_c;
    switch (script) {
      case TempScript::kModel:
        o.imu_temp_c = std::round(th.sensor_c * 100.0) / 100.0;
        break;
      case TempScript::kModelChamberOnly:
        break;
      case TempScript::kSinusoid:  // never settles: 0.3 degC/min peak rate
        o.imu_temp_c = -20.0 + 1.5 * std::sin(2 * kPi * t / 1800.0);
        break;
      case TempScript::kNone:
        o.chamber_temp_c.reset();
        break;
    }
    runner.tick(o);
    for (auto& e : runner.takeEvents()) {
      if (e.step == 0 && e.kind == RunnerEvent::Kind::kStepStarted) out.started = t;
      if (e.step == 0 && e.kind == RunnerEvent::Kind::kStepFinished) out.finished = t;
      out.events.push_back(std::move(e));
    }
  }
  out.exit = runner.exit();
  out.ramps = bench.ramps;
  return out;
}

TEST(PlanRunnerSoak, AutoSoakEndsWithinTenPercentOfTheModelsSettlingTime) {
  const calib::model::ThermalLag lag{600.0, 300.0};
  const auto steps = autoSoakSteps(lag, "5 h");
  ASSERT_EQ(steps.size(), 2u);
  ASSERT_TRUE(steps[0].soak_auto);
  const auto predicted = calib::model::settlingTime(
      calib::model::thermalAtRest(20.0), -20.0, 1.0 / 60.0, lag, {0.05 / 60.0, 600.0}, 5 * 3600.0);
  ASSERT_TRUE(predicted.settled);
  EXPECT_EQ(steps[0].planned_s, predicted.t_s);
  const SoakRun run = runSoak(steps, lag, TempScript::kModel);
  ASSERT_FALSE(run.ramps.empty());
  EXPECT_DOUBLE_EQ(run.ramps.front(), 1.0 / 60.0) << "the plan's ramp goes to the chamber";
  EXPECT_EQ(run.exit, RunExit::kCompleted);
  const double soaked = run.finished - run.started;
  std::cout << "auto soak: " << soaked << " s, model " << predicted.t_s << " s\n";
  EXPECT_NEAR(soaked, predicted.t_s, 0.1 * predicted.t_s);
  const RunnerEvent* settled = run.find(RunnerEvent::Kind::kSoakSettled);
  ASSERT_NE(settled, nullptr);
  EXPECT_NE(settled->message.find("the IMU temperature"), std::string::npos) << settled->message;
  EXPECT_EQ(run.find(RunnerEvent::Kind::kSoakTimeout), nullptr);
}

TEST(PlanRunnerSoak, NeverSettlingTemperatureEndsAtMaxSoakFlagged) {
  const calib::model::ThermalLag lag{600.0, 300.0};
  const auto steps = autoSoakSteps(lag, "3 h");
  const SoakRun run = runSoak(steps, lag, TempScript::kSinusoid);
  EXPECT_EQ(run.exit, RunExit::kCompleted) << "the plan goes on after the timeout";
  EXPECT_NEAR(run.finished - run.started, 3 * 3600.0, 1.5);
  const RunnerEvent* timeout = run.find(RunnerEvent::Kind::kSoakTimeout);
  ASSERT_NE(timeout, nullptr);
  EXPECT_EQ(timeout->label, steps[0].label);
  EXPECT_NE(timeout->message.find("soak_timeout"), std::string::npos);
  EXPECT_NE(timeout->message.find("flagged"), std::string::npos);
  EXPECT_EQ(run.find(RunnerEvent::Kind::kSoakSettled), nullptr);
  EXPECT_STREQ(runnerEventKindName(timeout->kind), "soak_timeout");
}

TEST(PlanRunnerSoak, WithoutImuTemperatureTheChamberIsWatchedAndTheEventSaysSo) {
  const calib::model::ThermalLag lag{600.0, 300.0};
  const auto steps = autoSoakSteps(lag, "5 h");
  const SoakRun run = runSoak(steps, lag, TempScript::kModelChamberOnly);
  EXPECT_EQ(run.exit, RunExit::kCompleted);
  const RunnerEvent* settled = run.find(RunnerEvent::Kind::kSoakSettled);
  ASSERT_NE(settled, nullptr);
  EXPECT_NE(settled->message.find("the chamber temperature (no IMU temperature"), std::string::npos)
      << settled->message;
  // The air settles before the IMU: the end lies between the ramp's end + hold and the IMU's
  // settling time.
  const double soaked = run.finished - run.started;
  EXPECT_GT(soaked, steps[0].ramp_s + 600.0);
  EXPECT_LT(soaked, steps[0].planned_s * 1.05);
}

TEST(PlanRunnerSoak, NoTemperatureAtAllEndsAtMaxSoakAndSaysWhy) {
  const calib::model::ThermalLag lag{600.0, 300.0};
  const auto steps = autoSoakSteps(lag, "2 h");
  const SoakRun run = runSoak(steps, lag, TempScript::kNone);
  EXPECT_EQ(run.exit, RunExit::kCompleted);
  EXPECT_NEAR(run.finished - run.started, 2 * 3600.0, 1.5);
  const RunnerEvent* timeout = run.find(RunnerEvent::Kind::kSoakTimeout);
  ASSERT_NE(timeout, nullptr);
  EXPECT_NE(timeout->message.find("no temperature"), std::string::npos) << timeout->message;
}

TEST(PlanRunnerSoak, SlopeWindowIsRobustToQuantisation) {
  SlopeWindow w(300.0);
  EXPECT_FALSE(w.slope());
  // 0.02 degC/min under a 0.01 degC quantiser, 10 Hz: a two-point difference is 0 or 6 degC/min.
  for (int i = 0; i <= 3000; ++i) {
    const double t = 0.1 * i;
    w.add(t, std::round((5.0 + 0.02 / 60.0 * t) * 100.0) / 100.0);
  }
  ASSERT_TRUE(w.slope());
  EXPECT_NEAR(*w.slope() * 60.0, 0.02, 0.004);
  EXPECT_NEAR(w.centerTime(), 150.0, 2.0);
}

// Continuous ramp: the chamber is commanded as the leg's first step starts, nobody waits.
TEST(PlanRunnerSoak, RampCommandGoesOutWithTheStepWithoutWaiting) {
  RunStep hold;
  hold.kind = calib::SegmentKind::kStatic;
  hold.label = "ramp1/rep01/rest";
  hold.planned_s = 2.0;
  hold.start_angles = hold.end_angles = {0.0, 0.0};
  hold.chamber_command_c = -40.0;
  FakeBench bench(2);
  PlanRunner runner({hold}, options(), bench);
  ASSERT_TRUE(runner.start(0.0).ok);
  double now = 0.0;
  while (runner.state() == RunnerState::kRunning && now < 10.0) {
    now += 0.05;
    runner.tick(bench.step(now, 0.05));
  }
  EXPECT_EQ(runner.exit(), RunExit::kCompleted);
  EXPECT_EQ(bench.setpoints, (std::vector<double>{-40.0}));
  EXPECT_NEAR(now, 2.0, 0.11);
}

int stepIndex(const std::vector<RunStep>& steps, const std::string& label) {
  for (const RunStep& s : steps) {
    if (s.label == label) return s.index;
  }
  ADD_FAILURE() << "no step " << label;
  return -1;
}

// Issue 28 item 4: no rotation may touch a gap in the recording. Killed inside a rate run
// (its hold before finished) or inside the hold after it (the rate run finished): the run goes
// on at the hold before the rate run, whose segment stays; the finished rate run's segment is
// void. A kill between two holds changes nothing.
TEST(GapRestart, ARotationNeverTouchesTheGap) {
  const auto direct = testing::libraryPlanSteps("direct_two_axis.toml");
  const int before = stepIndex(direct, "rate_z_up_before");
  const int rate = stepIndex(direct, "rate_z_up_pos");
  ASSERT_EQ(rate, before + 1);
  ASSERT_EQ(stepIndex(direct, "rate_z_up_pos_after"), rate + 1);
  GapRestart in_rate = resumeAfterGap(direct, before);  // killed inside rate_z_up_pos
  EXPECT_EQ(in_rate.step, before);
  EXPECT_EQ(in_rate.first_void, rate) << "nothing stored is void";
  GapRestart in_hold_after = resumeAfterGap(direct, rate);  // killed in rate_z_up_pos_after
  EXPECT_EQ(in_hold_after.step, before);
  EXPECT_EQ(in_hold_after.first_void, rate) << "the rate run lost its hold after";
  const int pos01 = stepIndex(direct, "pos01_z_up");
  GapRestart in_move = resumeAfterGap(direct, pos01);  // killed in to_pos02_y_up
  EXPECT_EQ(in_move.step, pos01 + 1);
  EXPECT_EQ(in_move.first_void, pos01 + 1);

  const auto nav = twelveRunSteps();
  const int run02 = stepIndex(nav, "run02_x_p1");
  GapRestart in_reversal = resumeAfterGap(nav, run02 - 1);  // killed inside run02_x_p1
  EXPECT_EQ(nav[static_cast<std::size_t>(run02 - 1)].label, "run02_x_p1_before");
  EXPECT_EQ(in_reversal.step, run02 - 1);
  EXPECT_EQ(in_reversal.first_void, run02);
  // Every step done: nothing runs again, even after a final rotation.
  std::vector<RunStep> ends_turning(nav.begin(), nav.begin() + run02 + 1);
  const GapRestart done = resumeAfterGap(ends_turning, run02);
  EXPECT_EQ(done.step, run02 + 1);
  // In the run (an IMU gap): a rotation right at the start has no step before it to repeat.
  EXPECT_EQ(gapRestart(nav, -1).step, 0);
}

// Item 5: a gap voids the rotation under way; the runner goes back to the hold before it: the
// table returns to the hold's position (not recorded where the rotation stopped), then the
// hold and the whole rotation run again.
TEST(PlanRunner, RepeatFromGoesBackToTheHoldsPositionAndRerunsTheRotation) {
  Harness h;
  ASSERT_TRUE(h.runner.start(h.now).ok);
  const int k = h.midRotation();
  ASSERT_GE(k, 1);
  const RunStep& hold = h.steps[static_cast<std::size_t>(k - 1)];
  ASSERT_EQ(hold.kind, calib::SegmentKind::kStatic);
  EXPECT_FALSE(h.runner.repeatFrom(k + 1, h.now, "later step").ok);
  const int stops = h.bench.stops;
  ASSERT_TRUE(h.runner.repeatFrom(k - 1, h.now, "IMU data gap").ok);
  EXPECT_EQ(h.bench.stops, stops + 1);
  EXPECT_EQ(h.runner.state(), RunnerState::kRunning);
  ASSERT_TRUE(h.until([&] { return h.count(RunnerEvent::Kind::kStepStarted, k - 1) == 2; }, 60));
  EXPECT_EQ(h.lastAlarm(), "IMU data gap");
  for (std::size_t a = 0; a < hold.start_angles.size(); ++a) {
    EXPECT_NEAR(std::remainder(h.bench.angle(static_cast<int>(a)) - hold.start_angles[a], 2 * kPi),
                0.0, 1e-3)
        << "the hold runs again at its own position, axis " << a;
  }
  ASSERT_TRUE(h.until([&] { return h.runner.currentStep() > k; }, 600.0));
  EXPECT_EQ(h.count(RunnerEvent::Kind::kStepStarted, k), 2);
  EXPECT_EQ(h.count(RunnerEvent::Kind::kStepFinished, k), 1);
  ASSERT_TRUE(h.until([&] { return h.finished(); }, 3.0 * h.runner.plannedTotalS()));
  EXPECT_EQ(h.runner.exit(), RunExit::kCompleted);
}

// A resume at a hold (resumeAfterGap) with the table where a killed rotation left it: the hold
// starts only once the table is back at its position.
TEST(PlanRunner, ResumedHoldReturnsToItsPositionFirst) {
  Harness h;
  const int run02 = stepIndex(h.steps, "run02_x_p1");
  const RunStep& hold = h.steps[static_cast<std::size_t>(run02 - 1)];
  ASSERT_TRUE(h.runner.startAt(h.now, run02 - 1).ok);
  h.tick();
  EXPECT_EQ(h.count(RunnerEvent::Kind::kStepStarted, run02 - 1), 0) << "not at its position";
  ASSERT_TRUE(h.until([&] { return h.count(RunnerEvent::Kind::kStepStarted) > 0; }, 60));
  for (std::size_t a = 0; a < hold.start_angles.size(); ++a) {
    EXPECT_NEAR(std::remainder(h.bench.angle(static_cast<int>(a)) - hold.start_angles[a], 2 * kPi),
                0.0, 1e-3);
  }
}

TEST(PlanRunner, OptionsAreChecked) {
  RunnerOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.comm_timeout_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("comm_timeout_s"), std::string::npos);
  o = RunnerOptions{};
  o.chamber_safe_setpoint_c = 50.0;
  o.chamber_over_temperature_c = 40.0;
  EXPECT_FALSE(o.IsValid(&why));
  o = RunnerOptions{};
  o.soak_rate_window_fraction = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("soak_rate_window_fraction"), std::string::npos);
}

}  // namespace
}  // namespace imubench::daemon
