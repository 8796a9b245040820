// Helpers shared by the CAN tests: shipped layouts and deterministic IMU samples.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "drivers/imu_decoder.h"
#include "drivers/imu_layout.h"
#include "nav/imu_sample.h"
#include "scratch_dir.h"

namespace imubench::drivers::testing {

inline std::string deviceFile(const std::string& name) {
  return std::string(IMUBENCH_IMU_DEVICE_DIR) + "/" + name;
}

inline ImuLayout loadShipped(const std::string& name) {
  io::Diagnostics diag(deviceFile(name));
  auto layout = loadImuLayoutFile(deviceFile(name), diag);
  EXPECT_TRUE(layout.has_value()) << diag.str();
  return layout.value_or(ImuLayout{});
}

// Samples of an IMU on a table turning about a tilted axis with noise (fixed seed), like the
// simulator's output: increments over each period, t = END of the interval, slow temperature.
inline nav::ImuSamples makeSamples(int n, double period, unsigned seed = 7, double t0 = 0.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  nav::ImuSamples out;
  out.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double t = t0 + (k + 1) * period;
    nav::ImuSample s;
    s.t = t;
    const imubench::Vec3 w(0.3 * std::sin(0.7 * t), -0.2 * std::cos(0.5 * t),
                           0.17 + 0.01 * noise(rng));
    const imubench::Vec3 f(0.4 * std::sin(0.3 * t) + 0.01 * noise(rng), -0.25 + 0.01 * noise(rng),
                           9.806 + 0.02 * noise(rng));
    s.dtheta = w * period;
    s.dvel = f * period;
    s.temp_c = 25.0 + 0.5 * std::sin(0.01 * t);
    out.push_back(s);
  }
  return out;
}

// Asserts decoded samples equal the originals within the layout's resolution.
inline void expectSameWithinResolution(const ImuLayout& layout, const nav::ImuSamples& sent,
                                       const std::vector<DecodedImuSample>& got) {
  ASSERT_EQ(got.size(), sent.size());
  const double tol_t = layout.resolution(ImuQuantity::kTime) + 1e-9;
  const double tol_temp = layout.resolution(ImuQuantity::kTemperature) + 1e-12;
  for (std::size_t k = 0; k < sent.size(); ++k) {
    ASSERT_NEAR(got[k].sample.t, sent[k].t, tol_t) << "sample " << k;
    for (int a = 0; a < 3; ++a) {
      const double tol_th =
          layout.resolution(static_cast<ImuQuantity>(static_cast<int>(ImuQuantity::kDthetaX) + a));
      const double tol_dv =
          layout.resolution(static_cast<ImuQuantity>(static_cast<int>(ImuQuantity::kDvelX) + a));
      ASSERT_GT(tol_th, 0.0);
      ASSERT_GT(tol_dv, 0.0);
      ASSERT_NEAR(got[k].sample.dtheta[a], sent[k].dtheta[a], tol_th * (1 + 1e-9) + 1e-15)
          << "sample " << k << " axis " << a;
      ASSERT_NEAR(got[k].sample.dvel[a], sent[k].dvel[a], tol_dv * (1 + 1e-9) + 1e-15)
          << "sample " << k << " axis " << a;
    }
    ASSERT_NEAR(got[k].sample.temp_c, sent[k].temp_c, tol_temp) << "sample " << k;
  }
}

}  // namespace imubench::drivers::testing
