// Issue 16's thermal scenario without GoogleTest (the thermal tests and bench/calibration's
// thermal benchmark share it): the cubic truth with bias hysteresis, the site, and the two
// thermal schedules of must-show 2, built directly from the direct plan's
// motion (the calibration body) and the one chamber/sensor lag model
// (calib/model/thermal_lag.h); shared by the thermal tests and bench/calibration's thermal
// benchmark (no GoogleTest here).
//   soak points: the chamber steps along setpoints (heating leg, then cooling leg), ramps to
//                each at a rate, waits until the IMU has settled, then runs the body once;
//   continuous ramp: the chamber ramps up and back down at a set rate while the body repeats
//                without pause; each repetition's segments are labelled "LEG/repNN/label" so
//                calib::thermalPointsFromRun makes one point of each.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "calib/direct_calibration.h"
#include "calib/model/motion.h"
#include "calib/model/thermal_coefficients.h"
#include "calib/model/thermal_lag.h"
#include "calib/sensor_model.h"
#include "calib/simulator.h"
#include "calib/thermal_model.h"
#include "nav/earth.h"
#include "nav/rotation.h"

namespace imubench::calib::testing {

// c0 of a navigation-grade-like IMU (accel bias ~5 ug/degC, gyro bias ~0.03 deg/h/degC,
// scales ~2 ppm/degC, misalignments
// ~0.2 arcsec/degC, cubic terms worth ~ a tenth of the change at the range ends); c1..c3 per kind
// (sign and size varied by entry so no two coefficients share a curve); dT/dt hysteresis on the
// biases only.
inline model::ThermalCoefficients cubicThermalTruth() {
  model::ThermalCoefficients c;
  c.t_ref_c = 20.0;
  // The range over which the cubic holds (the truth is clamped outside it): wider than the
  // -40..+60 degC the plans calibrate over, because a continuous ramp's IMU overshoots the
  // chamber's turning point by a fraction of a degree (the lags) and a real sensor's
  // coefficients do not stop changing at the calibration range's edge.
  c.t_min_c = -50.0;
  c.t_max_c = 70.0;
  const SensorModel s{{{1.0012, 0.9991, 1.0004},
                       {0.012, -0.008, 0.02},
                       {1.1e-3, -0.7e-3, 0.5e-3, 0.9e-3, -1.2e-3, 0.4e-3}},
                      {{1.0003, 0.9996, 1.0008},
                       {2e-6, -3e-6, 1.5e-6},
                       {0.8e-3, 0.6e-3, -0.9e-3, 0.3e-3, 1.0e-3, -0.5e-3}}};
  // (c1, c2, c3) magnitudes for scale, bias, misalignment of each triad.
  const double accel_k[3][3] = {{2e-6, 2e-8, 5e-10}, {5e-5, 5e-7, 1e-8}, {1e-6, 1e-8, 2e-10}};
  const double gyro_k[3][3] = {{2e-6, 2e-8, 5e-10}, {1.5e-7, 1.5e-9, 3e-11}, {1e-6, 1e-8, 2e-10}};
  const double hysteresis[2] = {2.0, 1e-3};  // accel m/s^2, gyro rad/s per degC/s
  for (const bool accel : {true, false}) {
    const auto block = (accel ? s.accel : s.gyro).block();
    model::ThermalTriad& t = accel ? c.accel : c.gyro;
    for (int i = 0; i < model::kTriadSize; ++i) {
      const int kind = i < model::kBias ? 0 : i < model::kMis ? 1 : 2;
      const double f = 1.0 + 0.15 * i;  // per-entry size
      const double sgn = i % 2 == 0 ? 1.0 : -1.0;
      model::ThermalCoefficient& k = t[static_cast<std::size_t>(i)];
      k.order = 3;
      k.poly[0] = block[static_cast<std::size_t>(i)];
      for (int n = 1; n <= 3; ++n) {
        const double mag = (accel ? accel_k : gyro_k)[kind][n - 1] * f;
        k.poly[static_cast<std::size_t>(n)] = (n == 2 ? -sgn : sgn) * mag;
      }
      if (kind == 1) {
        k.hysteresis = true;
        k.dTdt = sgn * hysteresis[accel ? 0 : 1] * f;
      }
    }
  }
  return c;
}

inline nav::Site thermalSite() {
  nav::Site s;
  s.latitude_rad = 58.0 * kDegToRad;
  s.height_m = 170.0;
  return s;
}

// Sensor temperature knots over [0, duration] for a chamber ramping at rate (degC/s; 0: at
// rest) with the IMU centred on temp_c at mid-run, in steady ramp: the program leads the
// sensor by rate (tau_chamber + tau_sensor) as calib/model/thermal_lag.h gives.
inline std::vector<TemperatureKnot> rampKnots(double temp_c, double rate, double duration,
                                              const model::ThermalLag& lag) {
  const double start = temp_c - 0.5 * rate * duration;
  model::ThermalState s{start + rate * (lag.chamber_tau_s + lag.sensor_tau_s),
                        start + rate * lag.sensor_tau_s, start};
  const double goal = rate > 0.0 ? 1e3 : rate < 0.0 ? -1e3 : start;
  std::vector<TemperatureKnot> knots{{0.0, s.sensor_c}};
  const double step = 10.0;
  for (double t = step; t <= duration + step; t += step) {
    s = model::advanceThermal(s, goal, std::abs(rate), lag, step);
    knots.push_back({t, s.sensor_c});
  }
  return knots;
}

// Appends the phases and segments of `from` to `to` (same axes), `shift` s later, each segment
// label passed through `relabel`; `to.duration` is the caller's.
template <class Relabel>
void appendShifted(Motion& to, const Motion& from, double shift, Relabel relabel) {
  for (std::size_t a = 0; a < from.axes.size(); ++a) {
    for (AxisPhase p : from.axes[a].phases()) {
      p.t0 += shift;
      to.axes[a].append(p);
    }
  }
  for (Segment s : from.segments) {
    s.t0 += shift;
    s.t1 += shift;
    s.label = relabel(s.label);
    to.segments.push_back(s);
  }
}

// `reps` copies of body back to back, starting at t0 (the body must end where it starts, as
// the bundled direct plan does, at home). Segment labels become "<prefix(k)>/<label>".
template <class Prefix>
Motion repeatMotion(const Motion& body, int reps, Prefix prefix) {
  Motion m;
  m.kind = body.kind;
  m.axes.resize(body.axes.size());
  for (int k = 0; k < reps; ++k) {
    appendShifted(m, body, k * body.duration,
                  [&](const std::string& label) { return prefix(k) + "/" + label; });
  }
  m.duration = reps * body.duration;
  return m;
}

// "up/rep03" style prefix of repetition k of a leg.
inline std::string repetitionLabel(const char* leg, int k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%s/rep%02d", leg, k + 1);
  return buf;
}

struct ThermalScheduleOptions {
  double t_low_c = -40.0, t_high_c = 60.0;  // the range to calibrate over
  double step_c = 10.0;                     // soak points: setpoint spacing
  double soak_ramp_rate = 1.0 / 60.0;       // soak points: chamber ramp between setpoints, degC/s
  // Soak points: the IMU counts as settled within this of the setpoint (degC): the soak
  // detector's criterion, as the points' temperature then drifts by less than their spread.
  double settle_tol_c = 0.05;
  double ramp_rate = 0.003;  // continuous ramp: chamber ramp rate, degC/s
  model::ThermalLag lag{300.0, 600.0};
};

// Time (s) the IMU needs to settle within tol of goal from state s under the lag model, found
// on a 1-s grid; s is advanced to that time.
inline double settleTime(model::ThermalState* s, double goal, double ramp, double tol,
                         const model::ThermalLag& lag) {
  double t = 0.0;
  while (std::abs(s->sensor_c - goal) > tol || std::abs(s->program_c - goal) > 1e-9) {
    *s = model::advanceThermal(*s, goal, ramp, lag, 1.0);
    t += 1.0;
  }
  return t;
}

// Soak-point schedule: setpoints t_low..t_high then back down to t_low (each point once per
// leg, the ends once each leg), starting soaked at t_low. Returns the chamber time (s) to
// settle + run the body at every setpoint.
struct SoakSchedule {
  std::vector<double> setpoints;  // in order
  std::vector<int> legs;          // +1 heating, -1 cooling (the approach direction)
  double chamber_time_s = 0.0;
};

inline SoakSchedule soakSchedule(double body_s, const ThermalScheduleOptions& o) {
  SoakSchedule out;
  const int n = static_cast<int>(std::lround((o.t_high_c - o.t_low_c) / o.step_c));
  for (int i = 0; i <= n; ++i)
    out.setpoints.push_back(o.t_low_c + i * o.step_c), out.legs.push_back(1);
  for (int i = n; i >= 0; --i)
    out.setpoints.push_back(o.t_low_c + i * o.step_c), out.legs.push_back(-1);
  model::ThermalState s = model::thermalAtRest(o.t_low_c);
  for (const double sp : out.setpoints) {
    out.chamber_time_s += settleTime(&s, sp, o.soak_ramp_rate, o.settle_tol_c, o.lag);
    out.chamber_time_s += body_s;
    s = model::advanceThermal(s, sp, o.soak_ramp_rate, o.lag, body_s);
  }
  return out;
}

// Continuous-ramp schedule: from soaked at t_low the program ramps to t_high + overshoot and
// back to t_low - overshoot (overshoot = the IMU's steady lag rate (tau_air + tau_imu), so the
// IMU itself spans the range), the body repeating the whole time. Returns the motion with the
// IMU temperature knots (every 10 s) and the chamber time.
struct RampSchedule {
  Motion motion;
  double chamber_time_s = 0.0;
  int reps_up = 0, reps_down = 0;
};

inline RampSchedule rampSchedule(const Motion& body, const ThermalScheduleOptions& o) {
  RampSchedule out;
  const double lead = o.ramp_rate * (o.lag.chamber_tau_s + o.lag.sensor_tau_s);
  const double top = o.t_high_c + lead, bottom = o.t_low_c - lead;
  const double t_up = (top - o.t_low_c) / o.ramp_rate, t_down = (top - bottom) / o.ramp_rate;
  out.reps_up = static_cast<int>(std::ceil(t_up / body.duration));
  out.reps_down = static_cast<int>(std::ceil(t_down / body.duration));
  Motion up = repeatMotion(body, out.reps_up, [](int k) { return repetitionLabel("up", k); });
  Motion down = repeatMotion(body, out.reps_down, [](int k) { return repetitionLabel("down", k); });
  // Append the cooling leg after the heating leg.
  const double shift = up.duration;
  appendShifted(up, down, shift, [](const std::string& label) { return label; });
  up.duration += down.duration;
  // Temperatures: the program turns at the top when the heating leg's repetitions end.
  model::ThermalState s = model::thermalAtRest(o.t_low_c);
  const double step = 10.0;
  up.temperature.push_back({0.0, s.sensor_c});
  for (double t = step; t <= up.duration + step; t += step) {
    const double goal = t <= shift ? top : bottom;
    s = model::advanceThermal(s, goal, o.ramp_rate, o.lag, step);
    up.temperature.push_back({t, s.sensor_c});
  }
  out.chamber_time_s = up.duration;
  out.motion = std::move(up);
  return out;
}

// The motion simulated with the thermal truth (null: the ideal sensor) on a table with the
// given geometric errors (default: perfect); the run as the direct calibrator's input. *error set
// when the simulator refuses.
inline DirectCalibrationInput simulateThermalRun(
    Motion motion, const model::ThermalCoefficients* truth, const NoiseModel& noise, double rate_hz,
    std::uint64_t seed, double end_s, std::string* error, const TableErrors& table = {}) {
  SimulatorInput si;
  si.world.site = thermalSite();
  si.world.truth.table_kind = motion.kind;
  si.world.truth.table = table;
  if (truth) si.world.thermal = *truth;
  si.world.noise = noise;
  si.motion = std::move(motion);
  SimOptions so;
  so.imu_rate_hz = rate_hz;
  so.table_rate_hz = 10.0;
  so.seed = seed;
  so.end_time_s = end_s;
  const Simulation sim = simulate(si, so);
  if (!sim.status.ok) *error = sim.status.message;
  DirectCalibrationInput in;
  in.geometry.kind = si.motion.kind;
  in.site = si.world.site;
  in.imu = sim.imu;
  in.table = sim.table;
  in.segments = sim.segments;
  return in;
}

// Mean residual of the compensated data against the ideal sensor's, per static segment and
// axis, in units of the white-noise floor of that segment's mean; RMS over segments and axes.
struct StaticResidual {
  double accel = 0.0, gyro = 0.0;  // RMS of residual / floor
};

inline StaticResidual staticResidual(const nav::ImuSamples& comp,
                                     const DirectCalibrationInput& ideal, const NoiseModel& noise,
                                     double rate_hz) {
  double sa = 0.0, sg = 0.0;
  int n = 0;
  const double dt = 1.0 / rate_hz;
  for (const Segment& s : ideal.segments) {
    if (s.kind != SegmentKind::kStatic) continue;
    Vec3 da = Vec3::Zero(), dg = Vec3::Zero();
    double len = 0.0;
    for (std::size_t k = 0; k < comp.size(); ++k) {
      if (comp[k].t - dt < s.t0 + 1.0 || comp[k].t > s.t1 - 1.0) continue;
      da += comp[k].dvel - ideal.imu[k].dvel;
      dg += comp[k].dtheta - ideal.imu[k].dtheta;
      len += dt;
    }
    if (len <= 0.0) continue;
    da /= len * noise.accel.white / std::sqrt(len);
    dg /= len * noise.gyro.white / std::sqrt(len);
    sa += da.squaredNorm();
    sg += dg.squaredNorm();
    n += 3;
  }
  return {std::sqrt(sa / n), std::sqrt(sg / n)};
}

// Accuracy of a fitted thermal model against the truth: the worst compensated static
// residual (in noise floors) over 10 soaked temperatures between the soak points
// (-35..+55 degC; the body's static positions up to end_s), and the worst relative error of
// the bias temperature coefficients c1..c3.
struct ThermalAccuracy {
  double worst_accel = 0.0, worst_gyro = 0.0;  // residual / noise floor
  double worst_bias_tempco = 0.0;              // relative
  bool extrapolated = false;                   // a check temperature fell outside the fit
  std::string error;                           // a simulation or compensation failed
};

inline ThermalAccuracy thermalAccuracy(const model::ThermalCoefficients& fit,
                                       const model::ThermalCoefficients& truth, Motion body,
                                       const NoiseModel& noise, double rate_hz,
                                       double end_s = 900.0) {
  ThermalAccuracy a;
  for (double T = -35.0; T <= 55.0 + 1e-9; T += 10.0) {
    body.temperature = {{0.0, T}};  // soaked: at rest at T
    const DirectCalibrationInput run =
        simulateThermalRun(body, &truth, noise, rate_hz, 7, end_s, &a.error);
    const DirectCalibrationInput ideal =
        simulateThermalRun(body, nullptr, NoiseModel::none(), rate_hz, 7, end_s, &a.error);
    if (!a.error.empty()) return a;
    const ThermalApplyResult comp = applyThermal(fit, run.imu);
    if (!comp.status.ok) {
      a.error = comp.status.message;
      return a;
    }
    a.extrapolated = a.extrapolated || comp.extrapolated_count > 0;
    const StaticResidual r = staticResidual(comp.compensated, ideal, noise, rate_hz);
    a.worst_accel = std::max(a.worst_accel, r.accel);
    a.worst_gyro = std::max(a.worst_gyro, r.gyro);
  }
  for (const bool accel : {true, false}) {
    for (int i = model::kBias; i < model::kBias + 3; ++i) {
      const auto& f = (accel ? fit.accel : fit.gyro)[static_cast<std::size_t>(i)];
      const auto& t = (accel ? truth.accel : truth.gyro)[static_cast<std::size_t>(i)];
      for (std::size_t n = 1; n <= 3; ++n) {
        a.worst_bias_tempco = std::max(a.worst_bias_tempco, std::abs(f.poly[n] / t.poly[n] - 1.0));
      }
    }
  }
  return a;
}

}  // namespace imubench::calib::testing
