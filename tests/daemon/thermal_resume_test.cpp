// Issue 16 item 6: a thermal run interrupted by an abort or by a daemon crash (kill -9: the
// store left `running`) resumes from the start of the interrupted temperature point; no
// finished point is repeated, none is lost, and the finished points' stored rows stay.
//
// The daemon's part is played here by ThermalDaemon: one runner, one Store and one RunWriter
// per daemon lifetime, storing each step's segment and then its step_finished checkpoint as
// imubenchd does (bench_daemon.cpp publish/closeStep), and resuming the way
// BenchDaemon::resumeInterrupted does (resumeStep, discardSegmentsFrom, resumePoint).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "daemon/plan_runner.h"
#include "daemon/store.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tests/daemon/scratch_dir.h"

namespace imubench::daemon {
namespace {

using testing::ScratchDir;

// -10 and +30 degC (from 20), a fixed soak, a tiny body: two moves and two holds per point.
constexpr const char* kThermalPlan = R"(
[plan]
name = "thermal_tiny"
[table]
kind = "two-axis"
max_rate = "30 deg/s"
max_accel = "30 deg/s^2"
[chamber]
min_temp = "-20 degC"
max_temp = "40 degC"
max_ramp = "10 degC/min"
initial = "20 degC"
[[step]]
type = "thermal"
setpoints = ["-10 degC", "30 degC"]
mode = "soak"
soak = "20 s"
  [[step.steps]]
  type = "move"
  outer = "90 deg"
  inner = "0 deg"
  label = "to_y_up"
  [[step.steps]]
  type = "hold"
  duration = "10 s"
  label = "y_up"
  [[step.steps]]
  type = "move"
  outer = "0 deg"
  inner = "0 deg"
  label = "to_z_up"
  [[step.steps]]
  type = "hold"
  duration = "10 s"
  label = "z_up"
)";

std::vector<RunStep> planSteps(const char* text) {
  io::Diagnostics diag("thermal_tiny.toml");
  auto plan = plans::parsePlan(text, "thermal_tiny.toml", diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  const auto ex = plans::expand(*plan);
  EXPECT_TRUE(ex.status.ok) << ex.status.message;
  return runSteps(ex.motion);
}

int indexOf(const std::vector<RunStep>& steps, const std::string& label) {
  for (const RunStep& s : steps) {
    if (s.label == label) return s.index;
  }
  ADD_FAILURE() << "no step " << label;
  return -1;
}

// A table that turns at a constant rate to its target, and a chamber that takes its setpoints.
class SimBench : public BenchPort {
 public:
  Status prepare() override { return {}; }
  Status moveTo(int axis, double angle, const drivers::MotionLimits&) override {
    target_[axis] = angle_[axis] + std::remainder(angle - angle_[axis], 2.0 * kPi);
    return {};
  }
  Status rotateBy(int axis, double delta, const drivers::MotionLimits&) override {
    target_[axis] = angle_[axis] + delta;
    return {};
  }
  Status stopAll() override {
    target_ = angle_;
    return {};
  }
  Status emergencyStop() override { return stopAll(); }
  Status chamberSetpoint(double c, double ramp_c_per_s) override {
    ramps.push_back(ramp_c_per_s);
    setpoints.push_back(c);
    return {};
  }
  BenchObservation observe(double t, double dt) {
    BenchObservation o;
    for (std::size_t a = 0; a < angle_.size(); ++a) {
      const double d = target_[a] - angle_[a];
      angle_[a] += std::clamp(d, -kRate * dt, kRate * dt);
      o.moving = o.moving || target_[a] != angle_[a];
      o.angles.push_back(std::remainder(angle_[a], 2.0 * kPi));
    }
    o.now_s = o.table_last_ok_s = o.imu_last_frame_s = t;
    o.plan_time_s = t;
    o.table_ok = true;
    o.chamber_temp_c = overheated ? 60.0 : setpoints.empty() ? 20.0 : setpoints.back();
    return o;
  }
  std::vector<double> setpoints, ramps;
  bool overheated = false;  // the chamber reads above the runner's over_temperature

 private:
  static constexpr double kRate = 60.0 * kDegToRad;
  std::vector<double> angle_ = {0.0, 0.0}, target_ = {0.0, 0.0};
};

RunnerOptions runnerOptions() {
  RunnerOptions o;
  o.chamber_safe_setpoint_c = 23.0;
  o.chamber_over_temperature_c = 45.0;
  return o;
}

// One lifetime of the daemon over the store at `db`; the bench (and the IMU clock `t`) outlive
// it, as the real ones outlive a daemon crash.
class ThermalDaemon {
 public:
  ThermalDaemon(const std::string& db, const std::vector<RunStep>& steps, SimBench& bench,
                double& t)
      : steps_(steps), bench_(bench), t_(t) {
    auto opened = Store::open(db);
    EXPECT_TRUE(opened.status.ok) << opened.status.message;
    store_ = std::move(opened.value);
  }
  Store& store() { return *store_; }
  PlanRunner& runner() { return *runner_; }

  std::int64_t start() {
    RunStart s;
    s.plan_name = "thermal_tiny";
    s.plan_toml = kThermalPlan;
    s.bench_name = "bench-a";
    s.imu_serial = "SN-T";
    s.imu_rate_hz = 1.0 / kDt;
    s.latitude_deg = 55.75;
    s.height_m = 150.0;
    const RunIdResult run = store_->beginRun(s);
    EXPECT_TRUE(run.status.ok) << run.status.message;
    run_ = run.value;
    writer_ = std::make_unique<RunWriter>(*store_, run_);
    runner_ = std::make_unique<PlanRunner>(steps_, runnerOptions(), bench_);
    EXPECT_TRUE(runner_->start(t_).ok);
    return run_;
  }

  // imubench resume RUN (BenchDaemon::resumeInterrupted); returns the step it resumed at.
  int resume(std::int64_t run) {
    run_ = run;
    ResumePoint point = store_->resumePoint(run);
    EXPECT_TRUE(point.status.ok) << point.status.message;
    const int next = resumeStep(steps_, point.last_finished_step);
    if (next <= point.last_finished_step) {
      const CountResult dropped = store_->discardSegmentsFrom(run, steps_[next].label);
      EXPECT_TRUE(dropped.status.ok) << dropped.status.message;
      point = store_->resumePoint(run);
    }
    const Status resumed = store_->resumeRun(run);
    EXPECT_TRUE(resumed.ok) << resumed.message;
    writer_ = std::make_unique<RunWriter>(*store_, run, point);
    runner_ = std::make_unique<PlanRunner>(steps_, runnerOptions(), bench_);
    EXPECT_TRUE(runner_->startAt(t_, next).ok);
    return next;
  }

  // One poll: an IMU sample at t, the runner's tick, its events stored as the daemon does.
  void tick() {
    t_ += kDt;
    nav::ImuSample s;
    s.t = t_;
    s.dvel = Vec3(0.0, 0.0, 9.81 * kDt);
    s.temp_c = bench_.setpoints.empty() ? 20.0 : bench_.setpoints.back();
    EXPECT_TRUE(writer_->appendImu(std::span(&s, 1)).ok);
    runner_->tick(bench_.observe(t_, kDt));
    for (const RunnerEvent& e : runner_->takeEvents()) onEvent(e);
  }
  template <class Pred>
  bool until(Pred pred, double limit_s = 3600.0) {
    const double end = t_ + limit_s;
    while (!pred() && t_ < end) tick();
    return pred();
  }
  bool stopped() const {
    return runner_->state() == RunnerState::kFinished || runner_->state() == RunnerState::kFaulted;
  }
  void close(RunState state, const std::string& reason) {
    EXPECT_TRUE(writer_->flush().ok);
    const Status st = store_->finishRun(run_, state, reason);
    EXPECT_TRUE(st.ok) << st.message;
  }

  std::vector<std::string> started;  // labels of the steps started, in order
  static constexpr double kDt = 0.1;

 private:
  void onEvent(const RunnerEvent& e) {
    if (e.kind == RunnerEvent::Kind::kPointRestarted) {  // BenchDaemon::discardPoint
      EXPECT_TRUE(writer_->flush().ok);
      const CountResult r =
          store_->discardSegmentsFrom(run_, steps_[static_cast<std::size_t>(e.step)].label);
      EXPECT_TRUE(r.status.ok) << r.status.message;
    }
    if (e.kind == RunnerEvent::Kind::kStepStarted) {
      started.push_back(e.label);
      step_t0_ = t_;
    }
    if (e.kind != RunnerEvent::Kind::kStepFinished) return;
    // The segment, then the checkpoint (committed after it).
    const RunStep& s = steps_[static_cast<std::size_t>(e.step)];
    calib::Segment seg;
    seg.t0 = step_t0_;
    seg.t1 = t_;
    seg.kind = s.kind;
    seg.label = s.label;
    seg.axis = s.axis;
    seg.angle = s.delta;
    seg.setpoint_c = s.setpoint_c;
    EXPECT_TRUE(writer_->appendSegment(seg).ok);
    EXPECT_TRUE(writer_->flush().ok);
    const RunEvent stored{run_, t_, EventSeverity::kInfo, "step_finished",
                          "{\"step\":" + std::to_string(e.step) + "}"};
    EXPECT_TRUE(store_->addEvent(stored).ok);
  }

  std::vector<RunStep> steps_;
  SimBench& bench_;
  double& t_;
  std::unique_ptr<Store> store_;
  std::unique_ptr<RunWriter> writer_;
  std::unique_ptr<PlanRunner> runner_;
  std::int64_t run_ = 0;
  double step_t0_ = 0.0;
};

std::vector<std::string> labels(const std::vector<RunStep>& steps, int from, int to) {
  std::vector<std::string> out;
  for (int k = from; k < to; ++k) out.push_back(steps[static_cast<std::size_t>(k)].label);
  return out;
}

std::vector<calib::Segment> storedSegments(Store& store, std::int64_t run) {
  const io::RecordingReadResult rec = store.loadRecording(run);
  EXPECT_TRUE(rec.status.ok) << rec.status.message;
  return rec.value.segments;
}

std::vector<double> storedImuTimes(Store& store, std::int64_t run, double t_end) {
  const io::RecordingReadResult rec = store.loadRecording(run);
  EXPECT_TRUE(rec.status.ok) << rec.status.message;
  std::vector<double> out;
  for (const nav::ImuSample& s : rec.value.imu) {
    if (s.t <= t_end) out.push_back(s.t);
  }
  return out;
}

enum class Interruption { kAbort, kCrash };

// Runs the tiny thermal plan, interrupts it inside the +30 degC point (its soak and first move
// done, its first hold under way), resumes it, and checks what ran and what is stored.
void interruptAndResume(Interruption how) {
  const std::vector<RunStep> steps = planSteps(kThermalPlan);
  ASSERT_EQ(steps.size(), 10u);
  const int point2 = indexOf(steps, "T30C/soak");
  const int cut = indexOf(steps, "T30C/y_up");
  ASSERT_EQ(steps[point2].kind, calib::SegmentKind::kSoak);
  ASSERT_EQ(cut, point2 + 2);
  ScratchDir dir("thermal-resume");
  const std::string db = dir.file("bench.db");
  SimBench bench;
  double t = 0.0;

  std::int64_t run = 0;
  std::vector<std::string> first_half;
  std::vector<calib::Segment> segments_before;
  std::vector<double> imu_before;
  double point1_end = 0.0;
  {
    ThermalDaemon d(db, steps, bench, t);
    run = d.start();
    ASSERT_TRUE(d.until([&] { return d.runner().currentStep() == cut; }));
    ASSERT_TRUE(
        d.until([&] { return !d.started.empty() && d.started.back() == steps[cut].label; }));
    d.tick();  // the hold under way
    segments_before = storedSegments(d.store(), run);
    ASSERT_EQ(segments_before.size(), static_cast<std::size_t>(cut));
    point1_end = segments_before[static_cast<std::size_t>(point2 - 1)].t1;
    imu_before = storedImuTimes(d.store(), run, point1_end);
    if (how == Interruption::kAbort) {
      ASSERT_TRUE(d.runner().abort(t).ok);
      ASSERT_TRUE(d.until([&] { return d.stopped(); }));
      ASSERT_EQ(d.runner().exit(), RunExit::kAborted);
      EXPECT_EQ(bench.setpoints.back(), 23.0) << "abort parks the chamber at its safe setpoint";
      d.close(RunState::kAborted, "aborted");
    }
    first_half = d.started;
    // kCrash: nothing closes the run; the store stays `running`, as kill -9 leaves it.
  }
  EXPECT_EQ(first_half, labels(steps, 0, cut + 1));

  ThermalDaemon d(db, steps, bench, t);
  if (how == Interruption::kCrash) {
    ASSERT_EQ(d.store().markInterruptedRuns().value, 1);  // the daemon's start-up
  }
  const int from = d.resume(run);
  EXPECT_EQ(from, point2) << "the interrupted point restarts at its chamber step";
  ASSERT_TRUE(d.until([&] { return d.stopped(); }));
  ASSERT_EQ(d.runner().exit(), RunExit::kCompleted);
  d.close(RunState::kFinished, "completed");

  // Across both halves: the finished point once, the interrupted one from its soak, the rest.
  EXPECT_EQ(d.started, labels(steps, point2, static_cast<int>(steps.size())));
  std::map<std::string, int> done;  // steps that ran to completion, counted across the halves
  for (int k = 0; k < cut; ++k) ++done[steps[k].label];
  for (const std::string& l : d.started) ++done[l];
  for (int k = 0; k < point2; ++k) EXPECT_EQ(done[steps[k].label], 1) << steps[k].label;
  EXPECT_EQ(bench.setpoints.back(), 30.0) << "the soak commanded the point's setpoint again";

  // Stored: one segment per step, in plan order; the finished point's exactly as before.
  const std::vector<calib::Segment> segs = storedSegments(d.store(), run);
  std::vector<std::string> seg_labels;
  for (const calib::Segment& s : segs) seg_labels.push_back(s.label);
  EXPECT_EQ(seg_labels, labels(steps, 0, static_cast<int>(steps.size())));
  for (int k = 0; k < point2 && k < static_cast<int>(segs.size()); ++k) {
    EXPECT_EQ(segs[k].t0, segments_before[k].t0) << k;
    EXPECT_EQ(segs[k].t1, segments_before[k].t1) << k;
  }
  EXPECT_GT(segs[point2].t0, segments_before[point2].t1) << "the point's soak ran again, later";
  EXPECT_EQ(storedImuTimes(d.store(), run, point1_end), imu_before)
      << "the finished point's samples are all kept";
  const EventListResult events = d.store().events(run);
  ASSERT_TRUE(events.status.ok);
  int discarded = 0;
  for (const RunEvent& e : events.value) discarded += e.kind == "segments_discarded" ? 1 : 0;
  EXPECT_EQ(discarded, 1);
}

TEST(ThermalResume, AbortMidPointResumesAtThePointsChamberStep) {
  interruptAndResume(Interruption::kAbort);
}

TEST(ThermalResume, CrashMidPointResumesAtThePointsChamberStep) {
  interruptAndResume(Interruption::kCrash);
}

// A fault inside a point that parks the chamber at its safe setpoint (over temperature): the
// run pauses; resume (in the same daemon) restarts the point at its chamber step.
TEST(ThermalResume, OverTemperatureMidPointRestartsThePointOnResume) {
  const std::vector<RunStep> steps = planSteps(kThermalPlan);
  const int point2 = indexOf(steps, "T30C/soak");
  const int cut = indexOf(steps, "T30C/y_up");
  ScratchDir dir("thermal-resume");
  SimBench bench;
  double t = 0.0;
  ThermalDaemon d(dir.file("bench.db"), steps, bench, t);
  const std::int64_t run = d.start();
  ASSERT_TRUE(d.until([&] { return !d.started.empty() && d.started.back() == steps[cut].label; }));
  bench.overheated = true;
  ASSERT_TRUE(d.until([&] { return d.runner().state() == RunnerState::kPaused; }));
  EXPECT_EQ(bench.setpoints.back(), 23.0);
  bench.overheated = false;
  d.tick();
  ASSERT_TRUE(d.runner().resume(t).ok);
  EXPECT_EQ(d.runner().currentStep(), point2);
  ASSERT_TRUE(d.until([&] { return d.stopped(); }));
  ASSERT_EQ(d.runner().exit(), RunExit::kCompleted);
  d.close(RunState::kFinished, "completed");
  std::vector<std::string> expected = labels(steps, 0, cut + 1);
  for (const std::string& l : labels(steps, point2, static_cast<int>(steps.size())))
    expected.push_back(l);
  EXPECT_EQ(d.started, expected);
  std::vector<std::string> seg_labels;
  for (const calib::Segment& s : storedSegments(d.store(), run)) seg_labels.push_back(s.label);
  EXPECT_EQ(seg_labels, labels(steps, 0, static_cast<int>(steps.size())));
}

// The rule on its own: the step after the last finished one, moved back to the chamber step of
// its temperature point; plans without chamber steps resume at the next step as before.
TEST(ThermalResume, ResumeStepGoesBackToThePointsChamberStep) {
  const std::vector<RunStep> steps = planSteps(kThermalPlan);
  ASSERT_EQ(steps.size(), 10u);
  EXPECT_EQ(resumeStep(steps, -1), 0);
  EXPECT_EQ(resumeStep(steps, 0), 0) << "T-10C/soak done, its body not: soak again";
  EXPECT_EQ(resumeStep(steps, 3), 0);
  EXPECT_EQ(resumeStep(steps, 4), 5) << "point done: the next point's soak";
  EXPECT_EQ(resumeStep(steps, 7), 5);
  EXPECT_EQ(resumeStep(steps, 9), 10) << "every step done";

  std::vector<RunStep> plain = steps;
  for (RunStep& s : plain) {
    if (s.kind == calib::SegmentKind::kSoak) s.kind = calib::SegmentKind::kStatic;
  }
  EXPECT_EQ(resumeStep(plain, 3), 4);
  // A continuous-ramp leg starts where its first step commands the chamber.
  plain[6].chamber_command_c = 40.0;
  EXPECT_EQ(resumeStep(plain, 7), 6);
  EXPECT_EQ(resumeStep(plain, 5), 6);
}

}  // namespace
}  // namespace imubench::daemon
