// The chamber and the IMU's temperature, once: how the chamber air and the sensor follow a
// setpoint. The plan expander (plans/expand.cpp) predicts a plan's temperature with it and the
// virtual chamber (drivers/virtual_chamber.cpp) runs it, so both agree.
//
// Three stages, each exact (closed form, no integration step):
//   program  the chamber's ramp generator: moves toward the goal at the ramp rate (degC/s;
//            0: jumps to the goal at once) and stops on it;
//   air      first-order lag of the chamber air behind the program, time constant
//            chamber_tau_s (the chamber device file's time_constant; 0: the air is the program);
//   sensor   first-order lag of the IMU behind the air, time constant sensor_tau_s (0: the
//            IMU is at the air temperature).
// With a linear program u(t) = u0 + r t the air is
//   x(t) = u(t) - r tau1 + (x0 - u0 + r tau1) e^(-t/tau1)
// and the sensor, driven by that x(t), has the matching two-exponential solution below.
// Pure double: nothing differentiates through the temperature history.
#pragma once

#include <algorithm>
#include <cmath>

namespace imubench::calib::model {

// Spacing (s) of the temperature knots written while a lag settles: short against any chamber
// time constant (minutes), so the knots' linear interpolation follows the exponentials.
inline constexpr double kThermalKnotSpacing = 1.0;

struct ThermalLag {
  double chamber_tau_s = 0.0;  // air behind the program, s (0: no lag)
  double sensor_tau_s = 0.0;   // IMU behind the air, s (0: no lag)
};

struct ThermalState {
  double program_c = 20.0;  // the ramp generator's output, degC
  double air_c = 20.0;      // chamber air, degC
  double sensor_c = 20.0;   // IMU, degC
};

// Everything at one temperature (a chamber at rest, e.g. at ambient).
inline ThermalState thermalAtRest(double temp_c) {
  return {temp_c, temp_c, temp_c};
}

namespace detail {

// Air and sensor after time h under the linear program u0 + r t (program itself not updated).
inline ThermalState lagLinear(const ThermalState& s, double u0, double r, const ThermalLag& lag,
                              double h) {
  const double tau1 = lag.chamber_tau_s, tau2 = lag.sensor_tau_s;
  ThermalState out = s;
  // Air: x(t) = A + r t + C e^(-t/tau1).
  const double A = tau1 > 0.0 ? u0 - r * tau1 : u0;
  const double C = tau1 > 0.0 ? s.air_c - A : 0.0;
  const double e1 = tau1 > 0.0 ? std::exp(-h / tau1) : 0.0;
  out.air_c = A + r * h + C * e1;
  if (!(tau2 > 0.0)) {
    out.sensor_c = out.air_c;
    return out;
  }
  // Sensor: y(t) = A + r (t - tau2) + P(t) + D e^(-t/tau2), P the response to C e^(-t/tau1).
  const double e2 = std::exp(-h / tau2);
  double p0 = 0.0, ph = 0.0;
  if (C != 0.0 && std::abs(tau1 - tau2) > 1e-9 * tau2) {
    const double k = C * tau1 / (tau1 - tau2);
    p0 = k;
    ph = k * e1;
  } else if (C != 0.0) {  // equal time constants: the resonant term
    ph = C * (h / tau2) * e2;
  }
  const double D = s.sensor_c - (A - r * tau2) - p0;
  out.sensor_c = A + r * (h - tau2) + ph + D * e2;
  return out;
}

}  // namespace detail

// The state after time h (s, >= 0) with the chamber told to go to goal_c at ramp_c_per_s
// (degC/s, > 0; 0 or less: a step). The program reaches the goal exactly and stays there.
inline ThermalState advanceThermal(const ThermalState& s, double goal_c, double ramp_c_per_s,
                                   const ThermalLag& lag, double h) {
  if (!(h > 0.0)) return s;
  ThermalState cur = s;
  if (!(ramp_c_per_s > 0.0)) cur.program_c = goal_c;
  const double gap = goal_c - cur.program_c;
  if (gap != 0.0) {  // ramp phase, up to the goal or to h
    const double r = gap > 0.0 ? ramp_c_per_s : -ramp_c_per_s;
    const double t_ramp = std::abs(gap) / ramp_c_per_s;
    const double hr = std::min(h, t_ramp);
    cur = detail::lagLinear(cur, cur.program_c, r, lag, hr);
    cur.program_c = hr < t_ramp ? s.program_c + r * hr : goal_c;
    h -= hr;
    if (!(h > 0.0)) return cur;
  }
  ThermalState out = detail::lagLinear(cur, goal_c, 0.0, lag, h);
  out.program_c = goal_c;
  return out;
}

// Time (s, from now) at which the program reaches the goal; 0 if it is there or steps.
inline double rampTime(const ThermalState& s, double goal_c, double ramp_c_per_s) {
  if (!(ramp_c_per_s > 0.0)) return 0.0;
  return std::abs(goal_c - s.program_c) / ramp_c_per_s;
}

// True once the program, the air and the sensor are all on the goal (within tol_c).
inline bool thermalSettled(const ThermalState& s, double goal_c, double tol_c = 1e-9) {
  return std::abs(s.program_c - goal_c) <= tol_c && std::abs(s.air_c - goal_c) <= tol_c &&
         std::abs(s.sensor_c - goal_c) <= tol_c;
}

// The IMU temperature's rate of change (degC/s) in state s while the program holds still (after
// its ramp): the sensor follows the air, the air the program.
inline double sensorRateAtRest(const ThermalState& s, const ThermalLag& lag) {
  if (lag.sensor_tau_s > 0.0) return (s.air_c - s.sensor_c) / lag.sensor_tau_s;
  if (lag.chamber_tau_s > 0.0) return (s.program_c - s.air_c) / lag.chamber_tau_s;
  return 0.0;
}

// When a soak is over: the IMU's |dT/dt| has stayed below rate_c_per_s for hold_s.
struct SettleCriterion {
  double rate_c_per_s = 0.05 / 60.0;  // degC/s
  double hold_s = 600.0;              // s
};

struct SettleTime {
  double t_s = 0.0;      // from the chamber command: the end of the hold, or max_s
  bool settled = false;  // false: the criterion was not met within max_s
};

// The model's settling time of a soak commanded now (goal_c at ramp_c_per_s from state s): the
// first time at which the IMU's predicted |dT/dt| has stayed below the criterion's rate for its
// hold, counted from the end of the program's ramp (a chamber cannot be soaked while its program
// still moves). Both the plan expander (a soak's planned duration) and the tests use it; the plan
// runner measures the same criterion on the bench. At most max_s (then settled = false).
inline SettleTime settlingTime(const ThermalState& s, double goal_c, double ramp_c_per_s,
                               const ThermalLag& lag, const SettleCriterion& c, double max_s) {
  const double t_ramp = rampTime(s, goal_c, ramp_c_per_s);
  if (!(t_ramp + c.hold_s <= max_s)) return {max_s, false};
  ThermalState cur = advanceThermal(s, goal_c, ramp_c_per_s, lag, t_ramp);
  cur.program_c = goal_c;
  // Step: fine against the hold and the time constants (the rate is smooth on their scale).
  double dt = std::max(c.hold_s / 200.0, 1e-3);
  for (double tau : {lag.chamber_tau_s, lag.sensor_tau_s}) {
    if (tau > 0.0) dt = std::min(dt, tau / 50.0);
  }
  double below_since = -1.0;
  for (long k = 0;; ++k) {
    const double t = t_ramp + static_cast<double>(k) * dt;
    if (t > max_s) break;
    if (std::abs(sensorRateAtRest(cur, lag)) < c.rate_c_per_s) {
      if (below_since < 0.0) below_since = t;
      if (t - below_since >= c.hold_s) return {t, true};
    } else {
      below_since = -1.0;
    }
    cur = detail::lagLinear(cur, goal_c, 0.0, lag, dt);
  }
  return {max_s, false};
}

}  // namespace imubench::calib::model
