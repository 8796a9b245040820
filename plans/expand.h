// Expansion of a (validated) plan into calib::Motion: exact acceleration-limited axis
// profiles, labelled segments, temperature knots. Pure: no files, clocks or printing.
//
// Profiles: every move / rotate / rate step is the table's own motion profile
// (calib/model/motion_profile.h, the one the virtual table executes): a trapezoid (accelerate
// at `accel` to `rate`, cruise, decelerate) or a triangle when the turn is too short to reach
// `rate`; a rate step changes the rate at `accel`, holds it for the step's duration and changes
// it back to 0. Each phase is one calib::AxisPhase with constant acceleration, so angle(t) is
// exact; the last phase of a move starts at exactly the target angle with zero rate.
// Position moves take the shortest way (|delta| <= 180 deg) on continuous axes and the direct
// way on limited axes; all axes of one move start together, the segment ends when the last
// one arrives. Angles are continuous (never wrapped): two +180 rotations end at 360 deg.
//
// Segments (what the calibrators look for):
//   hold    -> kStatic            rotate -> kRotate, axis index + signed angle (rad)
//   move    -> kMove (axis/angle set when exactly one axis moves, else axis = -1)
//   rate    -> kRotate, axis + total signed angle turned including the ramps
//   chamber -> kSoak (ramp at the ramp rate, then the soak; table static throughout)
//   chamber with soak = "auto" -> kSoak with soak_auto and its criterion; its length is the
//             model's predicted settling time (calib/model/thermal_lag.h settlingTime)
//   thermal -> soak mode: per setpoint (leg order, plans/plan.h thermalSetpoints) a kSoak
//             "T-40C/soak" and the body prefixed "T-40C/" (a revisited setpoint "T-40C#2/");
//             ramp mode: the body repeated ("ramp<leg>/rep<NN>/") until the model's ramp to the
//             leg's setpoint is over, the leg's first segment carrying chamber_command_c
//   record  -> no segment; sets Segment::recording for what follows.
// Zero-length segments (a move to where the table already is) are left out.
// Labels: the step's label (default: its type); inside repeats the repeat's label and the
// iteration are prefixed: "<repeat label>#<k>/<step label>" (k 1-based, "#k" only when
// count > 1; repeat label defaults to "repeat").
//
// Temperature (plans with [chamber]; without, no knots: Motion's constant 20 degC): the bench's
// thermal model (calib/model/thermal_lag.h, the one the virtual chamber runs) from [chamber]
// initial at rest: every chamber step ramps the chamber's program to its setpoint at its ramp
// rate, the air and the IMU lag it by options.thermal. Knots (the IMU's temperature) at t = 0,
// at every chamber step, at the end of every ramp, every kThermalKnotSpacing while a lag
// settles, and at the end; linear in between (exact without lag: the ramp itself). kSoak
// segments carry their setpoint (Segment::setpoint_c). The soak is timed from the end of the
// program's ramp, as a chamber controller times it.
#pragma once

#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/motion.h"
#include "calib/model/thermal_lag.h"
#include "plans/plan.h"

namespace imubench::plans {

struct ExpandOptions {
  // Table angles at t = 0, rad, one per axis in axis order; empty: all zero.
  std::vector<double> initial_angles;
  // The chamber's and the IMU's thermal time constants. Default none (the air follows the
  // ramp exactly): the plan does not know its chamber; a caller with the chamber's device
  // file passes its time_constant as chamber_tau_s.
  calib::model::ThermalLag thermal;

  bool IsValid(std::string* why) const;
};

struct ExpandResult {
  // Why not, when !ok (plan not validated, incomplete steps, bad options).
  Status status = Status::Error("not expanded");
  calib::Motion motion;
};

// Expands a plan that passed validatePlan(). A plan with problems gives status.ok false and the
// first problem found (run the validator for the full list).
ExpandResult expand(const Plan& plan, const ExpandOptions& options = {});

// The model's rest-to-rest profile (calib::model::moveProfile) appended to a trajectory: turns by
// `delta` (rad, signed) starting at rest at `angle0` at time `t0`, with |rate| <= max_rate and
// |accel| = max_accel (both > 0). Appends its phases (the final one at rest on the target)
// to `axis` and returns the profile's duration (0 and nothing appended when delta == 0).
double appendProfile(calib::AxisTrajectory& axis, double t0, double angle0, double delta,
                     double max_rate, double max_accel);

// Duration of that profile (calib::model::moveDuration).
double profileDuration(double delta, double max_rate, double max_accel);

}  // namespace imubench::plans
