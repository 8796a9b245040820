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
#include "tests/thermal/thermal_scenario.h"

namespace imubench::calib::testing {

// The scenario's simulation, failing the test when the simulator refuses.
inline DirectCalibrationInput simulateThermal(Motion motion,
                                              const model::ThermalCoefficients* truth,
                                              const NoiseModel& noise, double rate_hz,
                                              std::uint64_t seed, double end_s = 0.0,
                                              const TableErrors& table = {}) {
  std::string error;
  DirectCalibrationInput in =
      simulateThermalRun(std::move(motion), truth, noise, rate_hz, seed, end_s, &error, table);
  EXPECT_TRUE(error.empty()) << error;
  return in;
}

}  // namespace imubench::calib::testing
