#include <gtest/gtest.h>

#include "calib/sensor_model.h"

namespace imubench::calib {
namespace {

TriadModel sampleTriad() {
  TriadModel t;
  t.scale = Vec3(1.0 + 120e-6, 1.0 - 80e-6, 1.0 + 30e-6);
  t.bias = Vec3(2e-3, -1e-3, 5e-4);
  t.mis = {1e-3, -2e-3, 3e-4, 4e-4, -5e-4, 6e-4};
  return t;
}

TEST(SensorModel, MisalignmentMatrixLayoutMatchesInterchange) {
  const Misalignment m{1.0, 2.0, 3.0, 4.0, 5.0, 6.0};
  const Mat3 M = misalignmentMatrix(m);
  Mat3 expected;
  expected << 1, 1, -2, -3, 1, 4, 5, -6, 1;
  EXPECT_EQ(M, expected);
}

TEST(SensorModel, KnownNumbers) {
  TriadModel t;
  t.scale = Vec3(2.0, 1.0, 0.5);
  t.bias = Vec3(0.1, 0.2, 0.3);
  t.mis.yx = 0.01;
  t.mis.xz = 0.02;
  // reading = S (M in - b): in = (1, 0, 1)
  // M in = (1 - 0.02, -0.01, 1); minus bias = (0.88, -0.21, 0.7); scaled = (1.76, -0.21, 0.35)
  const Vec3 r = t.reading(Vec3(1.0, 0.0, 1.0));
  EXPECT_NEAR(r.x(), 1.76, 1e-15);
  EXPECT_NEAR(r.y(), -0.21, 1e-15);
  EXPECT_NEAR(r.z(), 0.35, 1e-15);
}

TEST(SensorModel, InverseIsExact) {
  const TriadModel t = sampleTriad();
  for (const Vec3& in : {Vec3(0.0, 0.0, 9.81), Vec3(1.0, -2.0, 3.0), Vec3(-9.8, 0.1, 0.2)}) {
    const Vec3 back = t.input(t.reading(in));
    EXPECT_LT((back - in).norm(), 1e-14 * (1.0 + in.norm()));
  }
}

TEST(SensorModel, SmallAngleLimitIsIdentityPlusSmallPart) {
  // M = I + A with A linear in the misalignments: the skew part rotates, the symmetric part
  // shears; for tiny angles reading ~ in + A in - b.
  const TriadModel t = [] {
    TriadModel x = sampleTriad();
    x.scale = Vec3::Ones();
    x.bias = Vec3::Zero();
    return x;
  }();
  const Mat3 A = t.M() - Mat3::Identity();
  EXPECT_LT(A.cwiseAbs().maxCoeff(), 2.1e-3);
  EXPECT_EQ(A.diagonal(), Vec3::Zero());
  const Vec3 in(0.3, -0.4, 9.8);
  EXPECT_LT((t.reading(in) - (in + A * in)).norm(), 1e-15 * in.norm() * 10);
  // The inverse is I - A to first order.
  const Vec3 back = t.input(in);
  EXPECT_LT((back - (in - A * in)).norm(), 1e-5 * in.norm());
}

}  // namespace
}  // namespace imubench::calib
