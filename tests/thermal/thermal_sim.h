// Test helpers for the thermal suite: a thermal truth with a cubic in every coefficient and
// hysteresis in the biases, and the bundled direct plan simulated under a temperature history
// from the one chamber/sensor lag model (calib/model/thermal_lag.h).
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "calib/direct_calibration.h"
#include "calib/model/thermal_lag.h"
#include "calib/simulator.h"
#include "calib/thermal_model.h"

namespace imubench::calib::testing {

// c0 of a navigation-grade-like IMU (accel bias ~5 ug/degC, gyro bias ~0.03 deg/h/degC,
// scales ~2 ppm/degC, misalignments
// ~0.2 arcsec/degC, cubic terms worth ~ a tenth of the change at the range ends); c1..c3 per kind
// (sign and size varied by entry so no two coefficients share a curve); dT/dt hysteresis on the
// biases only.
inline model::ThermalCoefficients cubicThermalTruth() {
  model::ThermalCoefficients c;
  c.t_ref_c = 20.0;
  c.t_min_c = -40.0;
  c.t_max_c = 60.0;
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

// The motion simulated with the thermal truth; the run as the direct calibrator's input.
inline DirectCalibrationInput simulateThermal(Motion motion,
                                              const model::ThermalCoefficients* truth,
                                              const NoiseModel& noise, double rate_hz,
                                              std::uint64_t seed, double end_s = 0.0) {
  SimulatorInput si;
  si.world.site = thermalSite();
  si.world.truth.table_kind = motion.kind;
  if (truth) si.world.thermal = *truth;
  si.world.noise = noise;
  si.motion = std::move(motion);
  SimOptions so;
  so.imu_rate_hz = rate_hz;
  so.table_rate_hz = 10.0;
  so.seed = seed;
  so.end_time_s = end_s;
  const Simulation sim = simulate(si, so);
  EXPECT_TRUE(sim.ok) << sim.error;
  DirectCalibrationInput in;
  in.geometry.kind = si.motion.kind;
  in.site = si.world.site;
  in.imu = sim.imu;
  in.table = sim.table;
  in.segments = sim.segments;
  return in;
}

}  // namespace imubench::calib::testing
