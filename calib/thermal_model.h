// Thermal compensation of IMU samples with an imubench-thermal/1 model
// (calib/model/thermal_coefficients.h): the coefficients at each sample's own temperature and
// temperature rate, then the exact inverse of eq. 1 (calib/model/sensor_equation.h input()).
// `imubench apply` and the thermal fit's checks use these functions; the simulator's thermal
// truth evaluates the same coefficient functions forward.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/thermal_coefficients.h"
#include "calib/sensor_model.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

// The sensor model (both triads) at temperature temp_c (degC) changing at temp_rate (degC/s);
// *extrapolated (optional) is set when temp_c lies outside the calibrated range.
SensorModel thermalSensorsAt(const model::ThermalCoefficients& c, double temp_c, double temp_rate,
                             bool* extrapolated = nullptr);

struct TemperatureRateOptions {
  // Window (s) of the least-squares slope through the temperatures around each sample: long
  // against temperature quantisation (0.01..0.1 degC steps of real IMUs), short against the
  // minutes over which a chamber changes its rate.
  double window_s = 60.0;

  bool IsValid(std::string* why) const;
};

// dT/dt (degC/s) at every sample: slope of a straight line through the finite temperatures
// within +-window/2 of it (0 where fewer than two lie there). Samples must be sorted by t.
std::vector<double> temperatureRates(const nav::ImuSamples& imu,
                                     const TemperatureRateOptions& options = {});

struct ThermalApplyOptions {
  TemperatureRateOptions rate;  // how Tdot is estimated from the recorded temperatures
};

struct ThermalApplyResult {
  // Why not (no temperatures, unsorted samples, bad options), when !ok.
  Status status = Status::Error("not applied");
  nav::ImuSamples compensated;     // increments of the true inputs: G dtheta + h dt (eq. 1 inverse)
  std::vector<double> temp_rate;   // degC/s per sample
  std::vector<bool> extrapolated;  // per sample: temperature outside the calibrated range
  std::size_t extrapolated_count = 0;
  double temp_min_c = 0.0, temp_max_c = 0.0;  // temperatures the recording covered
};

// Compensates every sample with the coefficients at its own temperature and rate. Refuses
// (ok false) a recording with a sample whose temperature is missing (NaN).
ThermalApplyResult applyThermal(const model::ThermalCoefficients& c, const nav::ImuSamples& imu,
                                const ThermalApplyOptions& options = {});

}  // namespace imubench::calib
