#include "daemon/plan_runner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

#include "io/enum_names.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

// What opens an interlock without a fault bit, as the operator reads it.
constexpr const char* kInterlockOpenCause =
    "the controller restarted, or it was opened at the bench";

}  // namespace

constexpr io::Named<RunnerState> kRunnerStateNames[] = {
    {RunnerState::kIdle, "idle"},         {RunnerState::kRunning, "running"},
    {RunnerState::kPaused, "paused"},     {RunnerState::kAborting, "aborting"},
    {RunnerState::kFinished, "finished"}, {RunnerState::kFaulted, "faulted"},
};

const char* runnerStateName(RunnerState s) {
  return io::nameOf(kRunnerStateNames, s, "?");
}

constexpr io::Named<RunExit> kRunExitNames[] = {
    {RunExit::kNone, "none"},
    {RunExit::kCompleted, "completed"},
    {RunExit::kAborted, "aborted"},
    {RunExit::kEmergencyStop, "emergency_stop"},
};

const char* runExitName(RunExit e) {
  return io::nameOf(kRunExitNames, e, "?");
}

constexpr io::Named<RunnerEvent::Kind> kRunnerEventKindNames[] = {
    {RunnerEvent::Kind::kState, "state"},
    {RunnerEvent::Kind::kStepStarted, "step_started"},
    {RunnerEvent::Kind::kStepFinished, "step_finished"},
    {RunnerEvent::Kind::kAlarm, "alarm"},
    {RunnerEvent::Kind::kSoakSettled, "soak_settled"},
    {RunnerEvent::Kind::kSoakTimeout, "soak_timeout"},
    {RunnerEvent::Kind::kPointRestarted, "point_restarted"},
};

const char* runnerEventKindName(RunnerEvent::Kind k) {
  return io::nameOf(kRunnerEventKindNames, k, "?");
}

namespace {

// The largest |rate| and |accel| of an axis' phases inside [t0, t1): exactly what the
// expander computed for the step (a triangle profile's peak, a trapezoid's cruise rate).
drivers::MotionLimits phaseLimits(const calib::AxisTrajectory& axis, double t0, double t1) {
  drivers::MotionLimits m;
  const std::vector<calib::AxisPhase>& ph = axis.phases();
  for (std::size_t k = 0; k < ph.size(); ++k) {
    const double begin = std::max(ph[k].t0, t0);
    const double end = std::min(k + 1 < ph.size() ? ph[k + 1].t0 : t1, t1);
    if (!(end > begin)) continue;
    const double rate_begin = ph[k].rate0 + ph[k].accel * (begin - ph[k].t0);
    const double rate_end = ph[k].rate0 + ph[k].accel * (end - ph[k].t0);
    m.rate = std::max({m.rate, std::abs(rate_begin), std::abs(rate_end)});
    m.accel = std::max(m.accel, std::abs(ph[k].accel));
  }
  return m;
}

// A step's planned profile of one axis (none for a step built without limits: the bench then
// refuses the command instead of guessing one).
drivers::MotionLimits stepLimits(const RunStep& s, int axis) {
  const auto a = static_cast<std::size_t>(axis);
  return a < s.limits.size() ? s.limits[a] : drivers::MotionLimits{};
}

}  // namespace

std::vector<RunStep> runSteps(const calib::Motion& motion) {
  std::vector<RunStep> out;
  out.reserve(motion.segments.size());
  for (const calib::Segment& seg : motion.segments) {
    RunStep s;
    s.index = static_cast<int>(out.size());
    s.label = seg.label;
    s.kind = seg.kind;
    s.planned_t0_s = seg.t0;
    s.planned_s = seg.t1 - seg.t0;
    for (const calib::AxisTrajectory& a : motion.axes) {
      s.start_angles.push_back(a.at(seg.t0).angle);
      s.end_angles.push_back(a.at(seg.t1).angle);
      s.limits.push_back(phaseLimits(a, seg.t0, seg.t1));
    }
    if (seg.kind == calib::SegmentKind::kRotate) {
      s.axis = seg.axis;
      s.delta = seg.angle;
    }
    s.setpoint_c =
        seg.kind == calib::SegmentKind::kSoak ? seg.setpoint_c : motion.temperatureAt(seg.t1);
    if (seg.kind == calib::SegmentKind::kSoak) {
      s.soak_auto = seg.soak_auto;
      s.settle_rate_c_per_s = seg.settle_rate_c_per_s;
      s.settle_hold_s = seg.settle_hold_s;
      s.max_soak_s = seg.max_soak_s;
      s.ramp_s = seg.ramp_s;
    }
    s.chamber_command_c = seg.chamber_command_c;
    if (seg.kind == calib::SegmentKind::kSoak || seg.chamber_command_c) {
      s.chamber_ramp_c_per_s = seg.ramp_c_per_s;
    }
    s.recording = seg.recording;
    out.push_back(std::move(s));
  }
  return out;
}

int temperaturePointStart(const std::vector<RunStep>& steps, int step) {
  const int last = static_cast<int>(steps.size()) - 1;
  for (int k = std::min(step, last); k >= 0; --k) {
    const RunStep& s = steps[static_cast<std::size_t>(k)];
    if (s.kind == calib::SegmentKind::kSoak || s.chamber_command_c) return k;
  }
  return step;
}

int resumeStep(const std::vector<RunStep>& steps, int last_finished) {
  const int next = std::max(last_finished + 1, 0);
  if (next >= static_cast<int>(steps.size())) return static_cast<int>(steps.size());
  return temperaturePointStart(steps, next);
}

GapRestart gapRestart(const std::vector<RunStep>& steps, int last_kept) {
  const int n = static_cast<int>(steps.size());
  auto kind = [&](int k) { return steps[static_cast<std::size_t>(k)].kind; };
  int first_void = std::clamp(last_kept + 1, 0, n);
  while (first_void > 0 && kind(first_void - 1) == calib::SegmentKind::kRotate) --first_void;
  int step = first_void;
  if (step > 0 && step < n && kind(step) == calib::SegmentKind::kRotate &&
      (kind(step - 1) == calib::SegmentKind::kStatic ||
       kind(step - 1) == calib::SegmentKind::kMove)) {
    --step;
  }
  return {step, first_void};
}

GapRestart resumeAfterGap(const std::vector<RunStep>& steps, int last_finished) {
  const int n = static_cast<int>(steps.size());
  const int next = resumeStep(steps, last_finished);
  if (next >= n) return {n, n};
  if (next <= last_finished) return {next, next};  // a temperature point restarts
  return gapRestart(steps, last_finished);
}

std::vector<drivers::MotionLimits> planLimits(const std::vector<RunStep>& steps) {
  std::vector<drivers::MotionLimits> out;
  for (const RunStep& s : steps) {
    if (out.size() < s.limits.size()) out.resize(s.limits.size());
    for (std::size_t a = 0; a < s.limits.size(); ++a) {
      out[a].rate = std::max(out[a].rate, s.limits[a].rate);
      out[a].accel = std::max(out[a].accel, s.limits[a].accel);
    }
  }
  return out;
}

bool RunnerOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (!(comm_timeout_s > 0.0)) return fail("comm_timeout_s must be positive");
  if (!(imu_timeout_s > 0.0)) return fail("imu_timeout_s must be positive");
  if (!(angle_tolerance_rad > 0.0 && angle_tolerance_rad < 0.1)) {
    return fail("angle_tolerance_rad must be in (0, 0.1)");
  }
  if (!(overdue_factor >= 1.0) || !(overdue_margin_s >= 0.0)) {
    return fail("overdue_factor must be >= 1 and overdue_margin_s >= 0");
  }
  if (!(soak_rate_window_fraction > 0.0 && soak_rate_window_fraction <= 1.0)) {
    return fail("soak_rate_window_fraction must be in (0, 1]");
  }
  if (chamber_safe_setpoint_c && chamber_over_temperature_c &&
      !(*chamber_over_temperature_c > *chamber_safe_setpoint_c)) {
    return fail("chamber_over_temperature_c must be above chamber_safe_setpoint_c");
  }
  return true;
}

PlanRunner::PlanRunner(std::vector<RunStep> steps, RunnerOptions options, BenchPort& port)
    : steps_(std::move(steps)), plan_limits_(planLimits(steps_)), options_(options), port_(port) {}

drivers::MotionLimits PlanRunner::returnLimits(int axis) const {
  const auto a = static_cast<std::size_t>(axis);
  if (a < plan_limits_.size() && plan_limits_[a].rate > 0.0 && plan_limits_[a].accel > 0.0) {
    return plan_limits_[a];
  }
  drivers::MotionLimits fastest;
  for (const drivers::MotionLimits& m : plan_limits_) {
    if (m.rate > fastest.rate) fastest = m;
  }
  return fastest;
}

void PlanRunner::emit(RunnerEvent::Kind kind, double now_s, std::string message) {
  RunnerEvent e;
  e.kind = kind;
  e.time_s = now_s;
  e.step = step_;
  if (step_ >= 0 && step_ < static_cast<int>(steps_.size())) e.label = steps_[step_].label;
  e.message = std::move(message);
  events_.push_back(std::move(e));
}

void PlanRunner::setState(RunnerState s, double now_s) {
  if (s == state_) return;
  state_ = s;
  emit(RunnerEvent::Kind::kState, now_s, runnerStateName(s));
}

void PlanRunner::interruptStep(double now_s) {
  step_interrupted_ = true;
  phase_ = Phase::kBegin;
  step_elapsed_s_ = 0.0;
  setState(RunnerState::kPaused, now_s);
}

const RunStep& PlanRunner::displayedStep() const {
  const int last = static_cast<int>(steps_.size()) - 1;
  return steps_[static_cast<std::size_t>(std::clamp(step_, 0, last))];
}

std::vector<RunnerEvent> PlanRunner::takeEvents() {
  return std::exchange(events_, {});
}

Status PlanRunner::start(double now_s) {
  return startAt(now_s, 0);
}

Status PlanRunner::startAt(double now_s, int first_step) {
  if (state_ != RunnerState::kIdle) {
    return {false, std::string("busy: the runner is ") + runnerStateName(state_)};
  }
  if (steps_.empty()) return {false, "the plan has no steps"};
  if (first_step < 0 || first_step >= static_cast<int>(steps_.size())) {
    return {false, "step " + std::to_string(first_step) + " is outside the plan's " +
                       std::to_string(steps_.size()) + " steps"};
  }
  if (const Status st = port_.prepare(); !st.ok) {
    return {false, "the bench is not ready: " + st.message};
  }
  step_ = first_step;
  phase_ = Phase::kBegin;
  step_interrupted_ = first_step > 0;
  setState(RunnerState::kRunning, now_s);
  return {};
}

Status PlanRunner::pause(double now_s) {
  if (state_ != RunnerState::kRunning) {
    return {false, std::string("nothing to pause: the runner is ") + runnerStateName(state_)};
  }
  issue(port_.stopAll(), now_s, "stop");
  interruptStep(now_s);
  return {};
}

Status PlanRunner::resume(double now_s) {
  if (state_ != RunnerState::kPaused) {
    return {false, std::string("nothing to resume: the runner is ") + runnerStateName(state_)};
  }
  if (last_ && (!last_->table_ok || now_s - last_->table_last_ok_s > options_.comm_timeout_s)) {
    return {false, "the table is not answering: resume when communication is back"};
  }
  if (last_ && !last_->table_fault.empty()) {
    return {false, "the table reports a fault (" + last_->table_fault + "): clear it first"};
  }
  if (last_ && !last_->interlock_closed) {
    return {false, std::string("the table's interlock is open (") + kInterlockOpenCause +
                       "): re-arm the bench (imubench rearm), then resume"};
  }
  if (last_ && now_s - last_->imu_last_frame_s > options_.imu_timeout_s) {
    return {false, "the IMU is silent: resume when its frames arrive again"};
  }
  if (last_ && last_->chamber_temp_c && options_.chamber_over_temperature_c &&
      *last_->chamber_temp_c > *options_.chamber_over_temperature_c) {
    return {false, "the chamber is still over temperature: resume when it is back below " +
                       std::to_string(*options_.chamber_over_temperature_c) + " degC"};
  }
  if (chamber_left_point_) {
    chamber_left_point_ = false;
    const int first = temperaturePointStart(steps_, step_);
    if (first < step_) {
      step_ = first;
      step_interrupted_ = true;
      emit(RunnerEvent::Kind::kPointRestarted, now_s,
           "the chamber left the point's setpoint: the point restarts at its chamber step");
    }
  }
  setState(RunnerState::kRunning, now_s);
  return {};
}

Status PlanRunner::abort(double now_s) {
  if (state_ != RunnerState::kRunning && state_ != RunnerState::kPaused) {
    return {false, std::string("nothing to abort: the runner is ") + runnerStateName(state_)};
  }
  issue(port_.stopAll(), now_s, "stop");
  if (options_.chamber_safe_setpoint_c) {
    issue(port_.chamberSetpoint(*options_.chamber_safe_setpoint_c, 0.0), now_s,
          "chamber safe setpoint");
  }
  setState(RunnerState::kAborting, now_s);
  return {};
}

Status PlanRunner::repeatFrom(int step, double now_s, const std::string& why) {
  if (state_ != RunnerState::kRunning && state_ != RunnerState::kPaused) {
    return {false, std::string("nothing to repeat: the runner is ") + runnerStateName(state_)};
  }
  if (step < 0 || step > step_ || step >= static_cast<int>(steps_.size())) {
    return {false, "step " + std::to_string(step) + " is not before the current step " +
                       std::to_string(step_)};
  }
  emit(RunnerEvent::Kind::kAlarm, now_s, why);
  if (state_ == RunnerState::kRunning) port_.stopAll();  // best effort: the alarm says why
  step_ = step;
  step_interrupted_ = true;
  phase_ = Phase::kBegin;
  step_elapsed_s_ = 0.0;
  return {};
}

void PlanRunner::emergencyStop(double now_s, const std::string& who) {
  const Status st = port_.emergencyStop();
  exit_ = RunExit::kEmergencyStop;
  emit(RunnerEvent::Kind::kAlarm, now_s,
       "emergency stop by " + who + (st.ok ? "" : " (the bench reported: " + st.message + ")"));
  setState(RunnerState::kFaulted, now_s);
}

// A failed command is a communication fault: alarm and pause (the step re-runs on resume).
bool PlanRunner::issue(const Status& st, double now_s, const std::string& what) {
  if (st.ok) return true;
  emit(RunnerEvent::Kind::kAlarm, now_s, what + " failed: " + st.message);
  if (state_ == RunnerState::kRunning) interruptStep(now_s);
  return false;
}

void PlanRunner::alarmAndPause(double now_s, const std::string& why) {
  emit(RunnerEvent::Kind::kAlarm, now_s, why);
  if (state_ == RunnerState::kRunning) {
    port_.stopAll();  // best effort: the alarm already says what is wrong
    interruptStep(now_s);
  }
}

// Returns false when a check paused the run (nothing else to do on this tick).
bool PlanRunner::safetyChecks(const BenchObservation& obs) {
  std::ostringstream why;
  const double table_silent = obs.now_s - obs.table_last_ok_s;
  const double imu_silent = obs.now_s - obs.imu_last_frame_s;
  if (!obs.table_fault.empty()) {
    why << "table fault: " << obs.table_fault << ": plan paused";
  } else if (!obs.interlock_closed && obs.table_ok) {
    why << "table interlock open (" << kInterlockOpenCause
        << "): motion stopped, plan paused; re-arm the bench (imubench rearm), then resume";
  } else if (table_silent > options_.comm_timeout_s) {
    why << "table not answering for " << table_silent << " s (timeout " << options_.comm_timeout_s
        << " s): motion stopped, plan paused";
  } else if (imu_silent > options_.imu_timeout_s) {
    why << "IMU silent for " << imu_silent << " s (timeout " << options_.imu_timeout_s
        << " s): plan paused, recording goes on";
  } else if (obs.chamber_temp_c && options_.chamber_over_temperature_c &&
             *obs.chamber_temp_c > *options_.chamber_over_temperature_c) {
    why << "chamber over temperature: " << *obs.chamber_temp_c << " degC > "
        << *options_.chamber_over_temperature_c << " degC: chamber to its safe setpoint, plan "
        << "paused";
    if (options_.chamber_safe_setpoint_c) {
      port_.chamberSetpoint(*options_.chamber_safe_setpoint_c, 0.0);
      chamber_left_point_ = true;
    }
  } else {
    return true;
  }
  alarmAndPause(obs.now_s, why.str());
  return false;
}

void PlanRunner::tick(const BenchObservation& obs) {
  last_ = obs;
  if (state_ == RunnerState::kAborting) {
    if (obs.table_ok && !obs.moving) {
      exit_ = RunExit::kAborted;
      setState(RunnerState::kFinished, obs.now_s);
    }
    return;
  }
  if (state_ != RunnerState::kRunning) return;
  if (!safetyChecks(obs)) return;
  advance(obs);
}

bool PlanRunner::arrived(const BenchObservation& obs, const std::vector<double>& target) const {
  if (!obs.table_ok || obs.moving || obs.angles.size() < target.size()) return false;
  for (std::size_t a = 0; a < target.size(); ++a) {
    const double d = std::remainder(obs.angles[a] - target[a], 2.0 * kPi);
    if (std::abs(d) > options_.angle_tolerance_rad) return false;
  }
  return true;
}

void PlanRunner::beginStep(const BenchObservation& obs) {
  const RunStep& s = steps_[step_];
  // A hold that runs again (a resume, a gap: gapRestart) may find the table where an
  // interrupted motion left it: it goes back to its position like a motion.
  const bool moves = s.kind == calib::SegmentKind::kRotate || s.kind == calib::SegmentKind::kMove ||
                     (s.kind == calib::SegmentKind::kStatic && step_interrupted_);
  // After a pause or an alarm the table may still be braking: command nothing until it rests
  // (a controller may refuse a new demand while moving, and the start angle must be exact).
  if (moves && (obs.moving || !obs.table_ok)) return;
  step_elapsed_s_ = 0.0;
  if (moves && !arrived(obs, s.start_angles)) {
    // Interrupted (or the table is not where the previous step left it): back to the start.
    for (std::size_t a = 0; a < s.start_angles.size(); ++a) {
      const int axis = static_cast<int>(a);
      if (!issue(port_.moveTo(axis, s.start_angles[a], returnLimits(axis)), obs.now_s, "move")) {
        return;
      }
    }
    phase_ = Phase::kReturning;
    phase_t0_s_ = obs.now_s;
    return;
  }
  commandStep(obs);
}

void PlanRunner::commandStep(const BenchObservation& obs) {
  const double now_s = obs.now_s;
  phase_plan_t0_s_ = obs.plan_time_s.value_or(obs.now_s);
  const RunStep& s = steps_[step_];
  // step_started marks the step's own command (after any return to its start): the daemon's
  // segment for this step begins here.
  emit(RunnerEvent::Kind::kStepStarted, now_s,
       step_interrupted_ ? "re-run from its start" : std::string(calib::segmentKindName(s.kind)));
  step_interrupted_ = false;
  saw_moving_ = false;
  phase_t0_s_ = now_s;
  // Continuous ramp: the chamber goes on to its next setpoint while the table works.
  if (s.chamber_command_c &&
      !issue(port_.chamberSetpoint(*s.chamber_command_c, s.chamber_ramp_c_per_s), now_s,
             "chamber setpoint")) {
    return;
  }
  switch (s.kind) {
    case calib::SegmentKind::kRotate:
      if (!issue(port_.rotateBy(s.axis, s.delta, stepLimits(s, s.axis)), now_s, "rotate")) return;
      phase_ = Phase::kMoving;
      return;
    case calib::SegmentKind::kMove:
      for (std::size_t a = 0; a < s.end_angles.size(); ++a) {
        if (std::abs(s.end_angles[a] - s.start_angles[a]) < options_.angle_tolerance_rad) continue;
        const int axis = static_cast<int>(a);
        if (!issue(port_.moveTo(axis, s.end_angles[a], stepLimits(s, axis)), now_s, "move")) {
          return;
        }
      }
      phase_ = Phase::kMoving;
      return;
    case calib::SegmentKind::kSoak:
      if (!issue(port_.chamberSetpoint(s.setpoint_c, s.chamber_ramp_c_per_s), now_s,
                 "chamber setpoint")) {
        return;
      }
      soak_ = SoakWatch{
          SlopeWindow(options_.soak_rate_window_fraction * s.settle_hold_s), {}, {}, false};
      phase_ = Phase::kWaiting;
      return;
    case calib::SegmentKind::kStatic:
      phase_ = Phase::kWaiting;
      return;
  }
}

void PlanRunner::finishStep(double now_s) {
  emit(RunnerEvent::Kind::kStepFinished, now_s, "");
  step_elapsed_s_ = 0.0;
  ++step_;
  phase_ = Phase::kBegin;
  if (step_ >= static_cast<int>(steps_.size())) {
    exit_ = RunExit::kCompleted;
    setState(RunnerState::kFinished, now_s);
  }
}

void PlanRunner::advance(const BenchObservation& obs) {
  const RunStep& s = steps_[step_];
  const double in_phase = obs.now_s - phase_t0_s_;
  const double overdue = options_.overdue_factor * s.planned_s + options_.overdue_margin_s;
  switch (phase_) {
    case Phase::kBegin:
      beginStep(obs);
      return;
    case Phase::kReturning:
      if (arrived(obs, s.start_angles)) {
        commandStep(obs);
      } else if (in_phase > overdue) {
        alarmAndPause(obs.now_s,
                      "step '" + s.label + "': the table did not reach the step's start");
      }
      return;
    case Phase::kMoving:
      step_elapsed_s_ = std::min(in_phase, s.planned_s);
      saw_moving_ = saw_moving_ || obs.moving;
      if ((saw_moving_ || in_phase >= s.planned_s) && arrived(obs, s.end_angles)) {
        finishStep(obs.now_s);
      } else if (in_phase > overdue) {
        std::ostringstream why;
        why << "step '" << s.label << "': motion not complete after " << in_phase << " s (planned "
            << s.planned_s << " s)";
        alarmAndPause(obs.now_s, why.str());
      }
      return;
    case Phase::kWaiting: {
      const double waited = obs.plan_time_s.value_or(obs.now_s) - phase_plan_t0_s_;
      step_elapsed_s_ = std::clamp(waited, 0.0, s.planned_s);
      const bool over = s.kind == calib::SegmentKind::kSoak && s.soak_auto
                            ? autoSoakOver(obs, waited)
                            : waited >= s.planned_s;
      if (over) finishStep(obs.now_s);
      return;
    }
  }
}

double PlanRunner::plannedTotalS() const {
  double total = 0.0;
  for (const RunStep& s : steps_) total += s.planned_s;
  return total;
}

double PlanRunner::progress() const {
  const double total = plannedTotalS();
  if (!(total > 0.0)) return state_ == RunnerState::kFinished ? 1.0 : 0.0;
  double done = step_elapsed_s_;
  for (int k = 0; k < std::min<int>(step_, static_cast<int>(steps_.size())); ++k) {
    done += steps_[k].planned_s;
  }
  return std::clamp(done / total, 0.0, 1.0);
}

double PlanRunner::etaS() const {
  return (1.0 - progress()) * plannedTotalS();
}

}  // namespace imubench::daemon
