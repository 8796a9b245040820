// Plan execution as a state machine, apart from any I/O: the daemon's event loop feeds it
// observations (table angles and status, when the IMU last spoke, chamber temperature) and
// the time; it commands the bench through a small port interface and queues events for the
// control socket and the store. Tests drive it with a simulated port and a fake clock.
//
// States:   idle --start--> running --pause--> paused --resume--> running --> finished
//                                \--abort--> aborting (motion stopping) --> finished (aborted)
//           any state --emergency stop--> faulted
// Steps are the expanded plan's segments (plans/expand.h), so what runs is exactly what the
// simulator and the calibrators assume. A step is a checkpoint: pause stops the table where
// it is; resume brings every axis back to the interrupted step's start and runs it again
// from its beginning (a half rotation is useless to the calibration; a repeated one is not).
//
// Safety (whatever the controller itself enforces): table silent beyond comm_timeout, IMU
// silent beyond imu_timeout, the interlock found open, a motion taking far longer than
// planned, or a failed command -> stop motion, pause, alarm; chamber above over_temperature ->
// chamber to its safe setpoint, stop, pause, alarm. Recording is the daemon's business and goes on
// through all of these.
//
// Angles: rad; the plan's angles are continuous (two +180 deg turns end at 360 deg), the
// table reports wrapped angles, so position checks compare modulo 2 pi.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/motion.h"
#include "drivers/device_errors.h"
#include "drivers/table.h"

namespace imubench::daemon {

enum class RunnerState { kIdle, kRunning, kPaused, kAborting, kFinished, kFaulted };
const char* runnerStateName(RunnerState s);

enum class RunExit { kNone, kCompleted, kAborted, kEmergencyStop };
const char* runExitName(RunExit e);

// One step of the plan as executed: a segment of the expanded motion.
struct RunStep {
  int index = 0;
  std::string label;
  calib::SegmentKind kind = calib::SegmentKind::kStatic;
  double planned_t0_s = 0.0;         // plan time at the start
  double planned_s = 0.0;            // planned duration
  std::vector<double> start_angles;  // rad, every axis, continuous
  std::vector<double> end_angles;    // rad, every axis, continuous
  int axis = -1;                     // kRotate: the turning axis
  double delta = 0.0;                // kRotate: signed turn (direction explicit), rad
  double setpoint_c = 0.0;           // kSoak: chamber setpoint at the end
  // kSoak with soak = "auto" (calib::Segment): over when the measured temperature rate stayed
  // below settle_rate_c_per_s for settle_hold_s, counted from ramp_s (the program's ramp); at
  // max_soak_s the step ends flagged (a soak_timeout event). planned_s is the model's prediction.
  bool soak_auto = false;
  double settle_rate_c_per_s = 0.0;
  double settle_hold_s = 0.0;
  double max_soak_s = 0.0;
  double ramp_s = 0.0;
  // kSoak and chamber_command_c: the plan's ramp rate (degC/s), sent with the setpoint so the
  // chamber ramps as the plan's times assume instead of at whatever rate it last had.
  double chamber_ramp_c_per_s = 0.0;
  // Continuous-ramp thermal plans: the chamber setpoint commanded (without waiting) as this
  // step starts.
  std::optional<double> chamber_command_c = std::nullopt;
  bool recording = true;
  // Per axis: the largest |rate| and |accel| the expansion planned inside this step (zero
  // where the axis rests). Sent with the step's motion commands, so the table follows the
  // plan's profile instead of its controller's maximum.
  std::vector<drivers::MotionLimits> limits;
};

// The plan's steps from its expansion. Pure.
std::vector<RunStep> runSteps(const calib::Motion& motion);

// Temperature points. A step that sets the chamber (a kSoak step: a chamber step, or the
// "T-40C/soak" that opens each setpoint of a thermal plan in soak mode; or a step carrying
// chamber_command_c: the first step of a continuous-ramp leg, plans/expand.h) starts a
// temperature point; the steps after it, up to the next such step, belong to that point and
// assume the chamber where that step took it. The first step of the point `step` belongs to;
// `step` itself before any chamber step. Pure.
int temperaturePointStart(const std::vector<RunStep>& steps, int step);

// Where a run resumes after an interruption (a daemon crash or stop, an abort, a fault) whose
// last finished step is `last_finished` (-1: none): the step after it, unless that step is
// inside a temperature point whose chamber step had finished, then that chamber step. After an
// abort or a fault the chamber went to its safe setpoint, after a crash it drifted: the point's
// motions may only run again after its soak. The points finished before stay done. Returns
// steps.size() when every step had finished. The one rule for this; the daemon
// (resumeInterrupted) discards the re-run steps' stored segments (Store::discardSegmentsFrom).
int resumeStep(const std::vector<RunStep>& steps, int last_finished);

// Where a run goes on after a gap in its recording (the daemon was down, the IMU restarted or
// went silent) that came after the stored segment of step `last_kept` (-1: none stored yet).
// No rotation may touch a gap: the calibrators integrate a rotation from inside the hold before
// it to inside the hold after it (calib/indirect/indirect_calibration.h run_pad_s,
// adjacency_tolerance_s; calib/static_detection.h checkIncrements refuses a gap next to a
// rotation). So
//   - a rotation stored right before the gap is void (its hold after is lost): it runs again,
//     and every step after it; first_void is the first step whose stored segment is discarded
//     (last_kept + 1 when none is);
//   - a rotation that runs again after the gap runs with the hold (or move) before it: `step`
//     is that step, whose segment stored before the gap is kept (it closes the rotation before
//     it); both are stored, one on each side of the gap.
// The interrupted step's partial samples stay stored and belong to no segment. Pure.
struct GapRestart {
  int step = 0;        // the step the run goes on at (steps.size(): none left)
  int first_void = 0;  // the first step whose stored segment is void
};
GapRestart gapRestart(const std::vector<RunStep>& steps, int last_kept);

// The crash-resume rule (BenchDaemon::resumeInterrupted): resumeStep's temperature point rule
// (a point restarts at its chamber step, its finished steps void), else gapRestart; nothing to
// run when every step had finished. Pure.
GapRestart resumeAfterGap(const std::vector<RunStep>& steps, int last_finished);

// Per axis, the largest rate and acceleration of any step (zero for an axis that never moves).
std::vector<drivers::MotionLimits> planLimits(const std::vector<RunStep>& steps);

// What the runner commands. The daemon implements it over the table and chamber drivers; a
// command returns at once (the motion is observed through BenchObservation).
class BenchPort {
 public:
  virtual ~BenchPort() = default;
  // Before the first step: the table ready to move (interlock closed). Refusal = no start.
  virtual Status prepare() = 0;
  // Position-mode motion at the step's rate and acceleration profile: moveTo takes the
  // shortest way, rotateBy's sign is the direction.
  virtual Status moveTo(int axis, double angle_rad, const drivers::MotionLimits& limits) = 0;
  virtual Status rotateBy(int axis, double delta_rad, const drivers::MotionLimits& limits) = 0;
  virtual Status stopAll() = 0;        // controlled stop
  virtual Status emergencyStop() = 0;  // table and chamber
  // The chamber to setpoint_c at ramp_c_per_s (degC/s; 0: at the ramp the controller has, e.g.
  // the safe setpoint after an alarm). No chamber: Ok.
  virtual Status chamberSetpoint(double setpoint_c, double ramp_c_per_s) = 0;
};

struct BenchObservation {
  double now_s = 0.0;            // monotonic
  bool table_ok = false;         // the last table read succeeded (the values below are fresh)
  double table_last_ok_s = 0.0;  // when a table read last succeeded
  std::vector<double> angles;    // rad, as read (wrapped or not)
  std::vector<double> rates;     // rad/s, per axis as `angles` (empty when not read)
  // When each angle was sampled (CLOCK_REALTIME s, drivers::unixTimeS; 0: unknown). Each axis
  // is read by its own request, so they differ by a round trip or more.
  std::vector<double> angles_unix_s;
  // Each angle's read round trip, s (drivers::TableAxisReading::round_trip_s; 0: unknown).
  std::vector<double> angles_round_trip_s;
  // DriverBenchPort::busyS() at this reading: the port's time in commands and chamber reads.
  double busy_s = 0.0;
  bool moving = false;  // any axis moving
  // The clock of the plan's holds and soaks: the IMU's own sample time when the daemon has
  // it (a virtual bench may run faster than the wall clock; the IMU's samples are what a
  // hold is for). Unset: now_s.
  std::optional<double> plan_time_s;
  std::string table_fault;  // non-empty: the controller reports a fault (interlock, estop)
  // The controller reports its interlock closed (meaningful when table_ok). It opens without a
  // fault when the controller restarts or someone opens it at the bench: motion is refused
  // until it is closed again (the daemon's `rearm`).
  bool interlock_closed = true;
  double imu_last_frame_s = 0.0;         // when the last IMU frame arrived
  std::optional<double> chamber_temp_c;  // measured, when there is a chamber
  // The IMU's own temperature (its newest frame's, plan_time_s); unset when its frames carry
  // none. Auto soaks watch it, else the chamber's.
  std::optional<double> imu_temp_c;
};

// Least-squares slope of a temperature over a sliding time window: robust against a quantised
// reading (a two-point difference of a 0.01 degC reading is mostly quantisation). Samples closer
// than window/kMaxSamples to the previous kept one are skipped, so memory and work are bounded
// whatever the frame rate.
class SlopeWindow {
 public:
  static constexpr int kMaxSamples = 200;
  explicit SlopeWindow(double window_s = 60.0) : window_s_(window_s) {}
  void clear() { t_.clear(), y_.clear(); }
  void add(double t_s, double temp_c);
  // degC/s over the window, once the samples span at least 90 % of it (nullopt before).
  std::optional<double> slope() const;
  double centerTime() const;  // the time the slope belongs to: the window's middle

 private:
  double window_s_;
  std::vector<double> t_, y_;
};

struct RunnerOptions {
  double comm_timeout_s = 1.0;  // bench file [safety]: table silent longer -> pause + alarm
  double imu_timeout_s = 0.5;   // bench file [safety]: IMU silent longer -> pause + alarm
  // A step is in position when every axis is within this of its target and nothing moves:
  // far above encoder resolution, far below anything a calibration would accept.
  double angle_tolerance_rad = 1e-3;
  // A motion is overdue after factor * planned + margin: controllers ramp differently from
  // the plan's profile, but a table that has not arrived by then is stuck.
  double overdue_factor = 2.0;
  double overdue_margin_s = 10.0;
  std::optional<double> chamber_safe_setpoint_c;  // where abort and alarms leave the chamber
  std::optional<double> chamber_over_temperature_c;
  // An auto soak's temperature rate is the least-squares slope over this fraction of its
  // settle_hold, attributed to the window's middle: long enough to average out a quantised
  // reading, short enough that its lag (half the window) stays small against the hold.
  double soak_rate_window_fraction = 0.5;
  bool IsValid(std::string* why) const;
};

struct RunnerEvent {
  // kSoakSettled / kSoakTimeout: an auto soak's end (message: how it was measured); a timeout
  // flags the temperature point (the plan goes on).
  // kPointRestarted: resume after an alarm that sent the chamber to its safe setpoint goes
  // back to the chamber step of the interrupted temperature point (step: that step); the
  // point's steps finished before are run again (their stored segments are void).
  enum class Kind {
    kState,
    kStepStarted,
    kStepFinished,
    kAlarm,
    kSoakSettled,
    kSoakTimeout,
    kPointRestarted
  };
  Kind kind = Kind::kState;
  double time_s = 0.0;
  int step = -1;
  std::string label;    // step label
  std::string message;  // state name, or the alarm's reason
};
const char* runnerEventKindName(RunnerEvent::Kind k);

class PlanRunner {
 public:
  PlanRunner(std::vector<RunStep> steps, RunnerOptions options, BenchPort& port);

  // Operator commands return ok, or why the command does not apply now.
  Status start(double now_s);
  // A run interrupted by a daemon crash or stop goes on at `first_step` (the step after its
  // last finished one): the table returns to that step's start and it runs whole; the steps
  // before it count as done. first_step == 0 is start().
  Status startAt(double now_s, int first_step);
  Status pause(double now_s);
  // After an alarm that sent the chamber to its safe setpoint (over temperature), resume
  // restarts the interrupted temperature point at its chamber step (resumeStep's rule).
  Status resume(double now_s);
  Status abort(double now_s);
  // A gap in the recording (the IMU restarted or went silent) voided the segments of the steps
  // from `step` (<= the current one; gapRestart) on: an alarm (why), motion stopped and the
  // run goes on at `step` from its start (the table returns to its start angles first). A
  // paused run stays paused and resumes there.
  Status repeatFrom(int step, double now_s, const std::string& why);
  void emergencyStop(double now_s, const std::string& who);  // works in every state

  void tick(const BenchObservation& obs);

  RunnerState state() const { return state_; }
  RunExit exit() const { return exit_; }
  int currentStep() const { return step_; }  // -1 before the first, size() when done
  const std::vector<RunStep>& steps() const { return steps_; }
  // The step to show an operator: the current one, the first before start, the last after
  // the end. Requires a non-empty plan (start() refuses an empty one).
  const RunStep& displayedStep() const;
  double plannedTotalS() const;
  double progress() const;  // 0..1 by planned time
  double etaS() const;      // remaining planned time (the interrupted step counted whole)
  std::vector<RunnerEvent> takeEvents();

 private:
  enum class Phase { kBegin, kReturning, kMoving, kWaiting };

  void setState(RunnerState s, double now_s);
  // Stops the current step where it is: it re-runs from its start on resume.
  void interruptStep(double now_s);
  void alarmAndPause(double now_s, const std::string& why);
  bool safetyChecks(const BenchObservation& obs);
  void advance(const BenchObservation& obs);
  void beginStep(const BenchObservation& obs);
  void commandStep(const BenchObservation& obs);
  void finishStep(double now_s);
  bool arrived(const BenchObservation& obs, const std::vector<double>& target) const;
  bool issue(const Status& st, double now_s, const std::string& what);
  // The profile of a return to a step's start (not a planned motion): the axis' own fastest
  // planned profile, else the fastest of the plan's, so no return outruns the plan.
  drivers::MotionLimits returnLimits(int axis) const;
  void emit(RunnerEvent::Kind kind, double now_s, std::string message);
  // An auto soak's detection on this observation; true when the step is over.
  bool autoSoakOver(const BenchObservation& obs, double waited_s);

  std::vector<RunStep> steps_;
  std::vector<drivers::MotionLimits> plan_limits_;  // planLimits(steps_)
  RunnerOptions options_;
  BenchPort& port_;
  RunnerState state_ = RunnerState::kIdle;
  RunExit exit_ = RunExit::kNone;
  int step_ = -1;
  Phase phase_ = Phase::kBegin;
  double phase_t0_s_ = 0.0;       // now_s when the phase began
  double phase_plan_t0_s_ = 0.0;  // plan clock when the phase began
  double step_elapsed_s_ = 0.0;   // planned-time progress inside the current step
  bool step_interrupted_ = false;
  // An alarm sent the chamber to its safe setpoint: resume restarts the temperature point.
  bool chamber_left_point_ = false;
  // The table was seen moving since the step's command: a full turn ends where it started,
  // so "in position" alone cannot tell done from not yet begun.
  bool saw_moving_ = false;
  // The auto soak in progress: its rate window, since when the rate is below the threshold
  // (plan clock), and which temperature it watches.
  struct SoakWatch {
    SlopeWindow window;
    std::optional<double> below_since_s;
    std::optional<bool> from_chamber;  // unset until a temperature came
    bool used_chamber = false;
  };
  SoakWatch soak_;
  std::optional<BenchObservation> last_;
  std::vector<RunnerEvent> events_;
};

}  // namespace imubench::daemon
