// Temperature-dependent sensor coefficients, once (interchange.md "Thermal compensation file",
// imubench-thermal/1): every coefficient of a triad's parameter block (calib/model/
// sensor_equation.h offsets: scales, biases, misalignments) is
//     c(T, Tdot) = sum_k poly[k] (T' - t_ref_c)^k + dTdt * Tdot,
// T the IMU's own temperature (degC), Tdot its rate (degC/s), T' = T clamped to the calibrated
// range [t_min_c, t_max_c] (outside it the polynomial is evaluated at the nearest edge and the
// use is flagged). The dT/dt term carries hysteresis: heating (Tdot > 0) and cooling (Tdot < 0)
// through the same temperature give different values. The simulator's thermal truth, the fit
// and the compensation all evaluate these functions, so truth and compensation cannot differ
// in form. Pure double (nothing differentiates through the temperature).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>

#include "calib/model/sensor_equation.h"

namespace imubench::calib::model {

// Highest polynomial order in a file (the fit's BIC chooses 0..kMaxThermalOrder).
inline constexpr int kMaxThermalOrder = 4;

// One coefficient over temperature.
struct ThermalCoefficient {
  int order = 0;                                    // highest power used (0..kMaxThermalOrder)
  std::array<double, kMaxThermalOrder + 1> poly{};  // poly[k] multiplies (T - t_ref)^k
  double dTdt = 0.0;                                // per degC/s; 0 without hysteresis
  bool hysteresis = false;                          // dTdt is part of the model (fitted/given)
  // 1-sigma of poly[0..order] and dTdt; zero where unknown (truth files).
  std::array<double, kMaxThermalOrder + 1> sigma_poly{};
  double sigma_dTdt = 0.0;
};

// A triad: one ThermalCoefficient per parameter-block entry (kScale, kBias, kMis offsets).
using ThermalTriad = std::array<ThermalCoefficient, kTriadSize>;

struct ThermalCoefficients {
  double t_ref_c = 20.0;   // polynomial origin, degC
  double t_min_c = -40.0;  // calibrated range, degC (the temperatures the data covered)
  double t_max_c = 60.0;
  ThermalTriad accel;  // constant part of scale ~1.0 (poly[0]), SI units as eq. 1
  ThermalTriad gyro;
};

// Where a temperature falls against the calibrated range.
struct ThermalEvaluationPoint {
  double temp_c = 0.0;        // the temperature the polynomial is evaluated at (clamped)
  bool extrapolated = false;  // the given temperature was outside [t_min_c, t_max_c]
};

inline ThermalEvaluationPoint thermalPoint(const ThermalCoefficients& c, double temp_c) {
  const double clamped = std::clamp(temp_c, c.t_min_c, c.t_max_c);
  return {clamped, clamped != temp_c};
}

// c(T, Tdot) of one coefficient at an already clamped temperature.
inline double thermalValue(const ThermalCoefficient& c, double dT, double temp_rate) {
  double v = 0.0;
  for (int k = c.order; k >= 0; --k) v = v * dT + c.poly[static_cast<std::size_t>(k)];  // Horner
  return v + (c.hysteresis ? c.dTdt * temp_rate : 0.0);
}

// The triad's parameter block (kTriadSize entries) at (T, Tdot); returns the range check.
inline ThermalEvaluationPoint thermalTriadBlock(const ThermalCoefficients& c,
                                                const ThermalTriad& triad, double temp_c,
                                                double temp_rate, double* block) {
  const ThermalEvaluationPoint p = thermalPoint(c, temp_c);
  for (int i = 0; i < kTriadSize; ++i) {
    block[i] = thermalValue(triad[static_cast<std::size_t>(i)], p.temp_c - c.t_ref_c, temp_rate);
  }
  return p;
}

}  // namespace imubench::calib::model
