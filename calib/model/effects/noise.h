// The noise unit (Stage::kNoise), a random process the simulator adds, not a deterministic term.
//   bias_instability: accel (m/s^2), gyro (rad/s) per axis: the Allan-deviation minimum (the
//   flat bottom of the curve) the slow random bias drift makes; tau_s (s): the averaging time
//   where it occurs. The simulator adds to each axis' reading a first-order Gauss-Markov bias b
//   (E[b^2] = sigma^2, correlation time T_c) whose own Allan deviation
//     sigma_A(tau)^2 = sigma^2 (2x - 3 + 4 e^-x - e^-2x) / x^2,  x = tau / T_c,
//   has its maximum, kAllanPeakRatio sigma, at x = kAllanPeakX: T_c = tau_s / kAllanPeakX and
//   sigma = B / kAllanPeakRatio put that maximum B at tau_s. (The curve of white noise plus
//   this drift has its minimum near tau_s when the white noise's N / sqrt(tau_s) is below B.)
#pragma once

#include <cmath>

#include "calib/model/effect_unit.h"

namespace imubench::calib::model::effects {

struct BiasInstability {
  static constexpr EffectId kId = EffectId::kBiasInstability;
  static constexpr int kAccel = 0;  // accel, 3
  static constexpr int kGyro = 3;   // gyro, 3
  static constexpr int kTau = 6;    // tau_s, 1

  // Maximum of sigma_A / sigma over x = tau / T_c and where it occurs (golden-section search
  // of the formula above to 1e-15).
  static constexpr double kAllanPeakX = 1.892617891896947;
  static constexpr double kAllanPeakRatio = 0.6173642831444413;

  // Gauss-Markov parameters of one axis' drift for the Allan minimum B at p[kTau].
  template <typename T>
  static void gaussMarkov(const T* p, const T& allan_min, T* sigma, T* correlation_time_s) {
    *sigma = allan_min / T(kAllanPeakRatio);
    *correlation_time_s = p[kTau] / T(kAllanPeakX);
  }
  // The Allan deviation of that drift at averaging time tau (for checks and reports).
  template <typename T>
  static T allanDeviation(const T& sigma, const T& correlation_time_s, const T& tau) {
    using std::exp;
    using std::sqrt;
    const T x = tau / correlation_time_s;
    return sigma * sqrt((T(2.0) * x - T(3.0) + T(4.0) * exp(-x) - exp(T(-2.0) * x)) / (x * x));
  }
};

}  // namespace imubench::calib::model::effects
