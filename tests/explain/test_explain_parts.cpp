// Parts of the model-discrepancy analysis: the Allan noise floor, the encoder spline, the
// chi-square survival function.
#include <gtest/gtest.h>

#include <cmath>

#include "calib/explain/explain_fit.h"
#include "calib/explain/explain_model.h"
#include "calib/explain/explain_noise.h"
#include "calib/noise.h"

namespace imubench::calib {
namespace {

TEST(ExplainNoise, WhiteNoiseDensityAndAveraging) {
  GaussianSource g(7);
  const double dt = 0.01, density = 2e-4;  // m/s/sqrt(s)
  std::vector<HoldReadings> holds(4);
  for (HoldReadings& h : holds) {
    h.dt = dt;
    for (int i = 0; i < 6000; ++i) {
      h.accel.push_back(Vec3(9.8, 0.0, 0.0) + g.next3() * density / std::sqrt(dt));
      h.gyro.push_back(g.next3() * 1e-5 / std::sqrt(dt));
    }
  }
  const NoiseFloor nf = noiseFloor(holds);
  ASSERT_TRUE(nf.status.ok) << nf.status.message;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(nf.white[c], density, 0.05 * density);
  for (int c = 3; c < 6; ++c) EXPECT_NEAR(nf.white[c], 1e-5, 0.05e-5);
  // The deviation of a 1 s mean of white noise is density / sqrt(1 s).
  EXPECT_NEAR(nf.sigmaOfMean(0, 1.0), density, 0.1 * density);
  EXPECT_NEAR(nf.sigmaOfMean(0, 0.25), density / 0.5, 0.1 * density / 0.5);
}

TEST(ExplainNoise, NoHoldsIsNotOk) {
  EXPECT_FALSE(noiseFloor({}).status.ok);
}

TEST(ExplainSpline, RateAndAccelerationOfAQuadraticMotion) {
  std::vector<double> t, a;
  for (int k = 0; k <= 400; ++k) {
    const double tk = 0.01 * k;
    t.push_back(tk);
    a.push_back(0.3 * tk * tk);  // accel 0.6 rad/s^2
  }
  const AxisSpline s(t, a);
  const AxisState x = s.at(2.005);
  EXPECT_NEAR(x.angle, 0.3 * 2.005 * 2.005, 1e-9);
  EXPECT_NEAR(x.rate, 0.6 * 2.005, 1e-6);
  EXPECT_NEAR(x.accel, 0.6, 1e-3);
}

TEST(ExplainFit, ChiSquareSurvival) {
  EXPECT_NEAR(chiSquareSurvival(3.841458820694124, 1), 0.05, 1e-9);
  EXPECT_NEAR(chiSquareSurvival(5.991464547107979, 2), 0.05, 1e-9);
  EXPECT_NEAR(chiSquareSurvival(7.814727903251178, 3), 0.05, 1e-9);
  EXPECT_NEAR(chiSquareSurvival(16.918977604620448, 9), 0.05, 1e-9);
}

}  // namespace
}  // namespace imubench::calib
