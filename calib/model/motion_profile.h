// The table axis' motion profile, once: how an acceleration-limited axis moves when told to go
// to an angle or to change its rate. The plan expander (plans/expand.cpp) predicts the plan's
// motion with it and the virtual table (drivers/virtual_table.cpp) executes commands with it,
// so a plan run on the virtual table moves exactly as the plan says, sample for sample.
//
// Profile: trapezoidal. The axis accelerates at +-max_accel up to a peak rate (max_rate, or
// less when the move is too short to reach it: a triangle), cruises, and brakes at max_accel
// to rest exactly on the target. A move may start from any state (a new command replaces the
// rest of a running one); a rest-to-rest move by distance d takes moveDuration(d).
// Jerk is not limited: the acceleration switches instantly between phases. Device files may
// state max_jerk (drivers/device_file.h) but no part of the bench uses it yet; a jerk-limited
// (S-curve) profile would need phases with a constant jerk, which calib::AxisPhase (constant
// acceleration) cannot express.
//
// The profile is a list of calib::AxisPhase (constant acceleration each), so angle, rate and
// acceleration at any t follow exactly from calib::stateIn; profileSample() states them.
// Pure double: nothing differentiates through the table's motion.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "calib/model/motion.h"

namespace imubench::calib::model {

// An axis is at rest below this rate (rad/s); a rate change smaller than it is no change.
inline constexpr double kRestRate = 1e-9;
// A move shorter than this (rad) from rest is already there.
inline constexpr double kNoMove = 1e-12;

struct ProfileLimits {
  double max_rate = 0.0;   // rad/s, > 0
  double max_accel = 0.0;  // rad/s^2, > 0
};

// Phases taking an axis from `start` (angle, rate) at time t0 to rest exactly at `target`
// (continuous angle, rad). The first phase starts at t0, the last one at rest on the target.
// Going the other way first is allowed: when the axis cannot stop before the target it brakes
// through zero and comes back.
inline std::vector<AxisPhase> moveProfile(double t0, const AxisState& start, double target,
                                          const ProfileLimits& lim) {
  const double a = lim.max_accel;
  const double x0 = start.angle, v0 = start.rate;
  const double d = target - x0;
  if (std::abs(d) < kNoMove && std::abs(v0) < kRestRate) return {{t0, target, 0.0, 0.0}};
  const double stop_dist = v0 * std::abs(v0) / (2.0 * a);
  const double dir = (d - stop_dist) >= 0 ? 1.0 : -1.0;
  // Peak speed of an accelerate-then-brake profile covering d, capped by the rate limit.
  const double vp =
      std::min(std::sqrt(std::max(0.0, (2.0 * a * dir * d + v0 * v0) / 2.0)), lim.max_rate);
  const double dv1 = dir * vp - v0;
  const double acc1 = dv1 >= 0 ? a : -a;
  const double t1 = std::abs(dv1) / a;
  const double x_after1 = x0 + v0 * t1 + 0.5 * acc1 * t1 * t1;
  const double brake = dir * vp * vp / (2.0 * a);
  const double cruise = (vp > 0) ? std::max(0.0, (target - brake - x_after1) * dir / vp) : 0.0;
  std::vector<AxisPhase> ph;
  double t = t0;
  ph.push_back({t, x0, v0, acc1});
  t += t1;
  if (cruise > 0) {
    ph.push_back({t, x_after1, dir * vp, 0.0});
    t += cruise;
  }
  ph.push_back({t, target - brake, dir * vp, -dir * a});
  t += vp / a;
  ph.push_back({t, target, 0.0, 0.0});
  return ph;
}

// Phases changing an axis' rate from start.rate to `rate` (rad/s, signed) at `accel` (> 0)
// from time t0, then holding it (the last phase runs on at `rate`).
inline std::vector<AxisPhase> rateProfile(double t0, const AxisState& start, double rate,
                                          double accel) {
  const double dv = rate - start.rate;
  if (std::abs(dv) < kRestRate) return {{t0, start.angle, rate, 0.0}};
  const double acc = dv > 0 ? accel : -accel;
  const double t1 = std::abs(dv) / accel;
  return {{t0, start.angle, start.rate, acc},
          {t0 + t1, start.angle + start.rate * t1 + 0.5 * acc * t1 * t1, rate, 0.0}};
}

// Angle, rate and acceleration at time t of an axis following `phases` (sorted by t0; before
// the first phase the axis holds its starting angle at rest).
inline AxisState profileSample(const std::vector<AxisPhase>& phases, double t) {
  if (phases.empty()) return {};
  auto it = std::upper_bound(phases.begin(), phases.end(), t,
                             [](double tt, const AxisPhase& p) { return tt < p.t0; });
  if (it == phases.begin()) return {phases.front().angle0, 0.0, 0.0};
  return stateIn(*(it - 1), t);
}

// Time from the first phase's start to the last one's (for a move: its duration).
inline double profileDuration(const std::vector<AxisPhase>& phases) {
  return phases.empty() ? 0.0 : phases.back().t0 - phases.front().t0;
}

// Duration of a rest-to-rest move by `distance` (rad, either sign); 0 for no move.
inline double moveDuration(double distance, const ProfileLimits& lim) {
  if (std::abs(distance) < kNoMove) return 0.0;
  return profileDuration(moveProfile(0.0, AxisState{}, distance, lim));
}

// State at time t (s since the start) of a rest-to-rest move by `distance` from angle 0.
inline AxisState moveSample(double t, double distance, const ProfileLimits& lim) {
  return profileSample(moveProfile(0.0, AxisState{}, distance, lim), t);
}

}  // namespace imubench::calib::model
