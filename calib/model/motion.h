// Table motion as the simulator and the calibrators see it: exact, piecewise-constant
// acceleration per axis, plus the segment list and the temperature history.
//
// This is the contract between plans/ (which expands a plan file into a Motion using the
// table's rate/acceleration limits) and the simulator / calibrators in calib/.
//
// Axis order everywhere (arrays, CSV columns): two-axis [outer, inner];
// three-axis [outer, middle, inner]. Angles are nominal table angles in rad (what an ideal
// encoder would read); encoder zero errors are applied by the table error model, not here.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <vector>

namespace imubench::calib {

enum class TableKind { kTwoAxis, kThreeAxis };

inline int axisCount(TableKind kind) {
  return kind == TableKind::kTwoAxis ? 2 : 3;
}

struct AxisState {
  double angle = 0.0;  // rad
  double rate = 0.0;   // rad/s
  double accel = 0.0;  // rad/s^2
};

// From t0 until the next phase starts: angle(t) = angle0 + rate0 (t-t0) + accel (t-t0)^2 / 2.
struct AxisPhase {
  double t0 = 0.0;
  double angle0 = 0.0;
  double rate0 = 0.0;
  double accel = 0.0;
};

// State of an axis following phase p at time t (holds p's starting state before p.t0).
inline AxisState stateIn(const AxisPhase& p, double t) {
  if (t < p.t0) return {p.angle0, 0.0, 0.0};
  const double d = t - p.t0;
  return {p.angle0 + p.rate0 * d + 0.5 * p.accel * d * d, p.rate0 + p.accel * d, p.accel};
}

// Piecewise-quadratic angle history of one axis. Phases are sorted by t0; before the first
// phase the axis holds phase 0's starting state, after the last it follows the last phase.
class AxisTrajectory {
 public:
  // Appends a phase; t0 must not decrease (our bug if it does).
  void append(const AxisPhase& p) {
    assert(phases_.empty() || p.t0 >= phases_.back().t0);
    phases_.push_back(p);
  }
  const std::vector<AxisPhase>& phases() const { return phases_; }
  bool empty() const { return phases_.empty(); }

  // State at the end of the last phase, extrapolated to time t.
  AxisState at(double t) const;

 private:
  std::vector<AxisPhase> phases_;
};

enum class SegmentKind { kStatic, kRotate, kMove, kSoak };

inline const char* segmentKindName(SegmentKind k) {
  switch (k) {
    case SegmentKind::kStatic:
      return "static";
    case SegmentKind::kRotate:
      return "rotate";
    case SegmentKind::kMove:
      return "move";
    case SegmentKind::kSoak:
      return "soak";
  }
  return "static";
}

// A labelled time span of the plan (segments.csv of interchange.md).
struct Segment {
  double t0 = 0.0;  // s
  double t1 = 0.0;  // s
  SegmentKind kind = SegmentKind::kStatic;
  std::string label;
  bool recording = true;  // false where the plan switched recording off
  // For kRotate: which axis turns (index into the axis order above) and by how much (rad,
  // signed: the direction is explicit, a 180-degree reversal is +pi or -pi).
  int axis = -1;
  double angle = 0.0;
  // For kSoak: the chamber setpoint (degC) the soak holds (the temperature history lags it).
  double setpoint_c = 0.0;
  // kSoak ended by the IMU's temperature instead of a fixed time (plan soak = "auto"): the soak
  // is over once |dT/dt| stayed below settle_rate_c_per_s for settle_hold_s, at most max_soak_s
  // after the chamber command (then the plan goes on and the point is flagged). t1 - t0 is the
  // model's predicted settling time (calib/model/thermal_lag.h settlingTime).
  bool soak_auto = false;
  double settle_rate_c_per_s = 0.0;  // degC/s
  double settle_hold_s = 0.0;        // s
  double max_soak_s = 0.0;           // s, from the chamber command
  double ramp_s = 0.0;               // kSoak: the program's predicted ramp time (no soak before)
  // kSoak and chamber_command_c: the ramp rate the plan commands the chamber at, degC/s.
  double ramp_c_per_s = 0.0;
  // Continuous-ramp thermal plans: the chamber is told to go to this setpoint (degC) when this
  // segment starts and nobody waits for it (the segment is the table's own step).
  std::optional<double> chamber_command_c = std::nullopt;
};

// Temperature history of the IMU as (t, degC) knots, linear in between, held outside.
struct TemperatureKnot {
  double t = 0.0;
  double temp_c = 0.0;
};

struct Motion {
  TableKind kind = TableKind::kTwoAxis;
  std::vector<AxisTrajectory> axes;          // axisCount(kind) entries
  std::vector<Segment> segments;             // sorted, non-overlapping
  std::vector<TemperatureKnot> temperature;  // empty: constant 20 degC
  double duration = 0.0;                     // s

  double temperatureAt(double t) const;
};

}  // namespace imubench::calib
