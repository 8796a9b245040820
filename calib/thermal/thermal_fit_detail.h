// Internals shared by the two halves of the thermal fit (calib/thermal/thermal_fit.cpp: per-point
// fit; calib/thermal/thermal_fit_joint.cpp: the joint fit of the raw rows with the table errors):
// the per-coefficient model choice (polynomial order and dT/dt term by BIC). Not a public API.
#pragma once

#include <string>
#include <vector>

#include "calib/model/thermal_coefficients.h"
#include "calib/thermal/thermal_fit.h"

namespace imubench::calib::thermal_detail {

// Weighted data of one coefficient: value_i = gain_i c(T_i, Tdot_i) + e_i (gain empty: 1; the
// joint fit's rows see a coefficient through the sensor equation's derivative).
struct CoefficientData {
  std::vector<double> dT, rate, value, sigma, gain;
};

struct FitContext {
  const ThermalFitOptions* options;
  double scale = 1.0;       // largest |T - t_ref|
  double rate_scale = 1.0;  // largest |Tdot|
  bool hysteresis = false;  // a dT/dt term may be tried
};

// Distinct temperatures among the values (closer than `same` count as one).
int distinctTemperatures(std::vector<double> t, double same);

// Chooses and fits the model of one coefficient; false (why) when it cannot be fitted.
bool fitCoefficient(const CoefficientData& d, const FitContext& ctx, model::ThermalCoefficient* out,
                    ThermalCoefficientFit* fit, std::string* why);

}  // namespace imubench::calib::thermal_detail
