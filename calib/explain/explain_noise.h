// The noise floor of a recording for the model-discrepancy analysis (calib/explain/explain.h):
// Allan deviations of the six reading channels (accel x/y/z, gyro x/y/z) over the static holds, the
// white-noise density and the bias instability read off them, and the standard deviation of a
// mean over any averaging time (what a residual averaged over a window must be compared with).
//
// Allan deviation (non-overlapping clusters, pooled over holds): for cluster length m samples,
// tau = m dt, adev(tau)^2 = 1/2 <(ybar_{k+1} - ybar_k)^2> over consecutive clusters inside each
// hold (a hold's mean, i.e. its attitude, never enters). For white noise the standard deviation
// of a tau-average equals adev(tau); for correlated noise (bias instability) adev flattens,
// which is what makes averaging stop helping: weights taken from adev(tau) are the proper
// weights for correlated noise at the averaging time used.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "base/status.h"
#include "nav/rotation.h"

namespace imubench::calib {

inline constexpr int kExplainChannels = 6;  // accel x, y, z, gyro x, y, z

// One static hold: readings (m/s^2, rad/s) at a constant sample interval.
struct HoldReadings {
  std::vector<Vec3> accel;
  std::vector<Vec3> gyro;
  double dt = 0.0;  // s
};

struct AllanPoint {
  double tau_s = 0.0;
  std::array<double, kExplainChannels> adev{};  // per channel, reading units
  long long pairs = 0;                          // cluster pairs pooled
};

struct NoiseFloorOptions {
  // Fewest cluster pairs for a point of the curve: fewer gives a deviation uncertain by more
  // than ~25 % (relative uncertainty ~ 1/sqrt(2 pairs)).
  int min_pairs = 8;
  // Floors of the deviation, reading units: a noise-free (simulated or quantised) recording
  // would otherwise give zero sigmas and infinite weights.
  double min_accel_adev = 1e-9;  // m/s^2
  double min_gyro_adev = 1e-12;  // rad/s
};

struct NoiseFloor {
  // Error when the holds give no point of the curve (none, or all too short for min_pairs).
  Status status = Status::Error("the static holds are too short for an Allan deviation");
  std::vector<AllanPoint> curve;  // increasing tau
  // White-noise density per channel: adev(tau) sqrt(tau) at the shortest tau (accel in
  // m/s/sqrt(s), gyro in rad/sqrt(s)).
  std::array<double, kExplainChannels> white{};
  // Bias instability per channel: the curve's minimum / 0.664 (reading units), at tau_min.
  std::array<double, kExplainChannels> bias_instability{};
  std::array<double, kExplainChannels> bias_instability_tau_s{};
  double total_static_s = 0.0;
  // Per channel, the median over holds of the number of distinct readings (values closer than
  // 1e-9 of the triad's magnitude are one) and whether the channel is resolution-limited: at
  // most kMaxResolutionValues distinct values, i.e. no noise (a noise-free simulation: one
  // value) or noise below the quantisation step (quantised data: two). Its Allan deviation is
  // then the options' floor or the quantisation, not the sensor's noise, and every figure in
  // noise-floor units (sigmas, normalised RMS) is meaningless.
  std::array<int, kExplainChannels> distinct_values{};
  std::array<bool, kExplainChannels> resolution_limited{};
  bool anyResolutionLimited() const;

  // Standard deviation of the mean of channel c over an averaging time tau (s): the curve
  // interpolated log-log; below its first point white scaling, beyond its last point held
  // flat (conservative: no more averaging gain than measured).
  double sigmaOfMean(int channel, double tau_s) const;
};

NoiseFloor noiseFloor(std::span<const HoldReadings> holds, const NoiseFloorOptions& options = {});

}  // namespace imubench::calib
