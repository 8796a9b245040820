#include <gtest/gtest.h>

#include "calib/effects.h"

namespace imubench::calib {
namespace {

PhysicsPoint samplePoint() {
  PhysicsPoint p;
  p.f_B = Vec3(0.5, -0.3, 9.79);
  p.w_IB_B = Vec3(1e-5, 0.2, 0.5);
  p.w_LB_B = Vec3(0.0, 0.2, 0.5);
  p.wdot_LB_B = Vec3(0.1, 0.0, -0.2);
  p.temp_c = 35.0;
  return p;
}

TEST(Effects, IdsRoundTripAndAreInterchangeNames) {
  for (EffectId id : kAllEffects) {
    const auto back = effectFromName(effectName(id));
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(*back, id);
    EXPECT_EQ(static_cast<int>(flatParamNames(id).size()), flatSize(id));
  }
  EXPECT_STREQ(effectName(EffectId::kGyroGSensitivity), "gyro_g_sensitivity");
  EXPECT_FALSE(effectFromName("angle_harmonics").has_value());
}

TEST(Effects, FlatVectorRoundTripWithNames) {
  EffectSet s;
  const std::vector<double> g = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  std::string why;
  ASSERT_TRUE(s.setFlat(EffectId::kGyroGSensitivity, g, &why)) << why;
  EXPECT_TRUE(s.has(EffectId::kGyroGSensitivity));
  // Row-major: name "G.xy" is row x, column y = G(0, 1).
  const auto names = flatParamNames(EffectId::kGyroGSensitivity);
  EXPECT_EQ(names[1], "gyro_g_sensitivity.G.xy");
  EXPECT_EQ(s.gyro_g_sensitivity->G(0, 1), 2.0);
  EXPECT_EQ(s.gyro_g_sensitivity->G(2, 0), 7.0);
  EXPECT_EQ(s.flat(EffectId::kGyroGSensitivity), g);
  // Wrong size and unknown names are refused.
  EXPECT_FALSE(s.setFlat(EffectId::kLeverArm, std::vector<double>{1.0}, &why));
  EXPECT_NE(why.find("lever_arm"), std::string::npos);
  EXPECT_FALSE(s.setParam(EffectId::kThermalBias, "k_acc", std::vector<double>{1, 2, 3}, &why));
  EXPECT_NE(why.find("k_acc"), std::string::npos);
  ASSERT_TRUE(s.setParam(EffectId::kThermalBias, "t_ref_c", std::vector<double>{25.0}, &why));
  EXPECT_EQ(s.thermal_bias->t_ref_c, 25.0);
  EXPECT_EQ((*s.param(EffectId::kThermalBias, "t_ref_c"))[0], 25.0);
  s.disable(EffectId::kThermalBias);
  EXPECT_FALSE(s.has(EffectId::kThermalBias));
}

TEST(Effects, NoEffectsIsThePlainSensorModel) {
  SensorModel m;
  m.accel.scale = Vec3(1.001, 0.999, 1.0);
  m.accel.bias = Vec3(0.01, 0.02, -0.03);
  m.gyro.mis.xy = 1e-3;
  const PhysicsPoint p = samplePoint();
  const Readings r = forwardReadings(m, EffectSet{}, p);
  EXPECT_LT((r.accel - m.accel.reading(p.f_B)).norm(), 1e-15);
  EXPECT_LT((r.gyro - m.gyro.reading(p.w_IB_B)).norm(), 1e-15);
}

TEST(Effects, EachTermIsItsFormula) {
  SensorModel m;  // ideal sensors, so terms appear unscaled
  const PhysicsPoint p = samplePoint();
  EffectSet s;
  std::string why;

  s.lever_arm = LeverArm{Vec3(0.1, -0.05, 0.2)};
  const Vec3 lever =
      p.wdot_LB_B.cross(s.lever_arm->r_m) + p.w_LB_B.cross(p.w_LB_B.cross(s.lever_arm->r_m));
  EXPECT_LT((effectTerm(EffectId::kLeverArm, m, s, p).accel - lever).norm(), 1e-15);

  GyroGSensitivity g;
  g.G = Mat3::Identity() * 1e-5;
  g.G(0, 2) = 2e-5;
  s = {};
  s.gyro_g_sensitivity = g;
  EXPECT_LT((effectTerm(EffectId::kGyroGSensitivity, m, s, p).gyro - g.G * p.f_B).norm(), 1e-15);

  s = {};
  s.thermal_bias = ThermalBias{Vec3(1e-4, 0, 0), Vec3(0, 0, 1e-7), 20.0};
  const Readings tb = effectTerm(EffectId::kThermalBias, m, s, p);
  EXPECT_NEAR(tb.accel.x(), -1e-4 * 15.0, 1e-17);
  EXPECT_NEAR(tb.gyro.z(), -1e-7 * 15.0, 1e-15);  // cancellation against |w| ~ 0.5

  s = {};
  s.thermal_scale = ThermalScale{Vec3(0, 0, 1e-5), Vec3::Zero(), 20.0};
  EXPECT_NEAR(effectTerm(EffectId::kThermalScale, m, s, p).accel.z(), 1e-5 * 15.0 * p.f_B.z(),
              1e-13);

  s = {};
  s.scale_asymmetry = ScaleAsymmetry{Vec3(0, 0, 1e-4)};
  PhysicsPoint neg = p;
  neg.w_IB_B.z() = -0.5;
  EXPECT_NEAR(effectTerm(EffectId::kScaleAsymmetry, m, s, p).gyro.z(), 1e-4 * 0.5, 1e-15);
  EXPECT_NEAR(effectTerm(EffectId::kScaleAsymmetry, m, s, neg).gyro.z(), 1e-4 * 0.5, 1e-15);

  s = {};
  s.accel_k2 = AccelK2{Vec3(0, 0, 1e-6)};
  EXPECT_NEAR(effectTerm(EffectId::kAccelK2, m, s, p).accel.z(), 1e-6 * p.f_B.z() * p.f_B.z(),
              1e-13);

  // Time and site effects carry no instantaneous term.
  s = {};
  s.time_delay = TimeDelay{1e-3};
  EXPECT_EQ(effectTerm(EffectId::kTimeDelay, m, s, p).accel, Vec3::Zero());
}

}  // namespace
}  // namespace imubench::calib
