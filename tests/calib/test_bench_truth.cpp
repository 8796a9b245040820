#include <gtest/gtest.h>

#include "calib/bench_truth.h"

namespace imubench::calib {
namespace {

using nlohmann::json;

BenchTruth sampleTruth(TableKind kind) {
  BenchTruth t;
  t.table_kind = kind;
  t.sensors.accel.scale = Vec3(1.0001, 0.9998, 1.00005);
  t.sensors.accel.bias = Vec3(1e-3, -2e-3, 3e-3);
  t.sensors.accel.mis = {1e-4, 2e-4, 3e-4, 4e-4, 5e-4, 6e-4};
  t.sensors.gyro.scale = Vec3(1.00002, 1.0, 0.99997);
  t.sensors.gyro.bias = Vec3(1e-7, 2e-7, -3e-7);
  t.sensors.gyro.mis = {-1e-5, 2e-5, -3e-5, 4e-5, -5e-5, 6e-5};
  t.table.base_tilt = Vec2(1e-4, -2e-4);
  t.table.mounting = Vec2(3e-4, 4e-4);
  t.table.nonorthogonality = {5e-5, kind == TableKind::kThreeAxis ? 6e-5 : 0.0,
                              kind == TableKind::kThreeAxis ? 7e-5 : 0.0};
  t.table.encoder_zero = {1e-5, kind == TableKind::kThreeAxis ? 2e-5 : 0.0, 3e-5};
  t.extra.lever_arm = LeverArm{Vec3(0.01, 0.02, 0.03)};
  GyroGSensitivity g;
  g.G << 1, 2, 3, 4, 5, 6, 7, 8, 9;
  g.G *= 1e-6;
  t.extra.gyro_g_sensitivity = g;
  t.extra.thermal_bias = ThermalBias{Vec3(1e-5, 2e-5, 3e-5), Vec3(1e-9, 2e-9, 3e-9), 25.0};
  t.extra.time_delay = TimeDelay{1.5e-3};
  return t;
}

void expectSame(const BenchTruth& a, const BenchTruth& b) {
  EXPECT_EQ(flatNames(a), flatNames(b));
  EXPECT_EQ(flatValues(a), flatValues(b));
  EXPECT_EQ(a.table_kind, b.table_kind);
}

TEST(BenchTruth, JsonRoundTripBothTableKinds) {
  for (TableKind kind : {TableKind::kTwoAxis, TableKind::kThreeAxis}) {
    const BenchTruth t = sampleTruth(kind);
    const json j = toJson(t);
    // Through text as a file would go.
    const json reparsed = json::parse(j.dump());
    BenchTruth back;
    std::string why;
    ASSERT_TRUE(fromJson(reparsed, &back, &why)) << why;
    expectSame(t, back);
  }
}

TEST(BenchTruth, JsonLayoutIsInterchange) {
  const json j = toJson(sampleTruth(TableKind::kTwoAxis));
  EXPECT_EQ(j["accel"]["scale"].size(), 3u);
  EXPECT_DOUBLE_EQ(j["accel"]["misalignment"]["zy"].get<double>(), 6e-4);
  EXPECT_EQ(j["table"]["nonorthogonality"].size(), 1u);
  EXPECT_EQ(j["table"]["encoder_zero"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["extra"]["gyro_g_sensitivity"]["G"][0][1].get<double>(), 2e-6);
  EXPECT_DOUBLE_EQ(j["extra"]["time_delay"]["tau_s"].get<double>(), 1.5e-3);
  const json j3 = toJson(sampleTruth(TableKind::kThreeAxis));
  EXPECT_EQ(j3["table"]["nonorthogonality"].size(), 3u);
  EXPECT_DOUBLE_EQ(j3["table"]["nonorthogonality"][2].get<double>(), 5e-5);  // nu2_y
}

TEST(BenchTruth, MissingKeysKeepDefaults) {
  BenchTruth t;
  std::string why;
  ASSERT_TRUE(fromJson(json::parse(R"({"gyro": {"bias": [1e-6, 0, 0]}})"), &t, &why)) << why;
  EXPECT_EQ(t.sensors.accel.scale, Vec3::Ones());
  EXPECT_DOUBLE_EQ(t.sensors.gyro.bias.x(), 1e-6);
  EXPECT_TRUE(t.extra.enabled().empty());
}

struct Malformed {
  const char* json;
  const char* path;  // must appear in the message
};

TEST(BenchTruth, MalformedInputsAreRefusedNamingThePath) {
  const Malformed cases[] = {
      {R"([1, 2])", "(root)"},
      {R"({"accel": {"misalignment": {"xy": "big"}}})", "accel.misalignment.xy"},
      {R"({"accel": {"misalignment": {"xw": 0}}})", "accel.misalignment.xw"},
      {R"({"accel": {"scale": [1, 1]}})", "accel.scale"},
      {R"({"accel": {"scale": [1, 0, 1]}})", "accel.scale[1]"},
      {R"({"gyro": {"bias": [0, null, 0]}})", "gyro.bias[1]"},
      {R"({"gyro": {"offset": [0, 0, 0]}})", "gyro.offset"},
      {R"({"gyro": 5})", "gyro"},
      {R"({"table": {"base_tilt": [0, 0, 0]}})", "table.base_tilt"},
      {R"({"table": {"nonorthogonality": [0, 0]}})", "table.nonorthogonality"},
      {R"({"table": {"nonorthogonality": [0], "encoder_zero": [0, 0, 0]}})", "table.encoder_zero"},
      {R"({"extra": {"warp_drive": {}}})", "extra.warp_drive"},
      {R"({"extra": {"lever_arm": {"r": [0, 0, 0]}}})", "extra.lever_arm.r"},
      {R"({"extra": {"lever_arm": {"r_m": [0, 0]}}})", "extra.lever_arm.r_m"},
      {R"({"extra": {"gyro_g_sensitivity": {"G": [[0, 0, 0], [0, 0]]}}})",
       "extra.gyro_g_sensitivity.G"},
      {R"({"extra": {"time_delay": {"tau_s": [1]}}})", "extra.time_delay.tau_s"},
      {R"({"sensors": {}})", "sensors"},
  };
  for (const Malformed& c : cases) {
    BenchTruth t;
    std::string why;
    EXPECT_FALSE(fromJson(json::parse(c.json), &t, &why)) << c.json;
    EXPECT_NE(why.find(c.path), std::string::npos) << c.json << " -> " << why;
  }
}

TEST(BenchTruth, FlatNamesAndSetters) {
  BenchTruth t = sampleTruth(TableKind::kThreeAxis);
  const auto names = flatNames(t);
  EXPECT_EQ(names.front(), "accel.scale.x");
  EXPECT_NE(std::find(names.begin(), names.end(), "table.nonorthogonality.middle_y"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "extra.lever_arm.r_m.z"), names.end());
  std::string why;
  ASSERT_TRUE(setFlatValue(&t, "gyro.misalignment.zx", 0.25, &why)) << why;
  EXPECT_EQ(t.sensors.gyro.mis.zx, 0.25);
  ASSERT_TRUE(setFlatValue(&t, "extra.accel_k2.k2.y", 1e-6, &why)) << why;
  EXPECT_EQ(t.extra.accel_k2->k2.y(), 1e-6);
  EXPECT_EQ(*flatValue(t, "extra.accel_k2.k2.y"), 1e-6);
  EXPECT_FALSE(setFlatValue(&t, "gyro.misalignment.zz", 0.0, &why));
  EXPECT_NE(why.find("gyro.misalignment.zz"), std::string::npos);
}

TEST(BenchTruth, CoefficientReportCarriesSigmaAndObservable) {
  CoefficientReport r;
  r.values = sampleTruth(TableKind::kTwoAxis);
  r.setSigma("accel.bias.y", 1e-5);
  r.setSigma("gyro.misalignment.xy", 2e-6);
  r.setSigma("extra.lever_arm.r_m.x", 1e-3);
  r.setUnobservable("table.mounting.x");
  r.setUnobservable("accel.misalignment.zy");
  const json j = toJson(r);
  EXPECT_DOUBLE_EQ(j["accel"]["sigma"]["bias"][1].get<double>(), 1e-5);
  EXPECT_TRUE(j["accel"]["sigma"]["bias"][0].is_null());
  EXPECT_EQ(j["accel"]["observable"]["misalignment"]["zy"], false);
  EXPECT_EQ(j["table"]["observable"]["mounting"][0], false);
  EXPECT_EQ(j["table"]["observable"]["mounting"][1], true);
  EXPECT_DOUBLE_EQ(j["extra"]["lever_arm"]["sigma"]["r_m"][0].get<double>(), 1e-3);

  CoefficientReport back;
  std::string why;
  ASSERT_TRUE(fromJson(json::parse(j.dump()), &back, &why)) << why;
  expectSame(r.values, back.values);
  ASSERT_EQ(back.uncertainty.size(), r.uncertainty.size());
  for (const auto& [name, u] : r.uncertainty) {
    ASSERT_TRUE(back.uncertainty.count(name)) << name;
    EXPECT_EQ(back.uncertainty.at(name).sigma, u.sigma) << name;
    EXPECT_EQ(back.uncertainty.at(name).observable, u.observable) << name;
  }
  // A truth reader ignores the estimate siblings.
  BenchTruth t;
  ASSERT_TRUE(fromJson(j, &t, &why)) << why;
  // Malformed sigma is refused with its path.
  json bad = j;
  bad["accel"]["sigma"]["bias"][1] = "x";
  EXPECT_FALSE(fromJson(bad, &back, &why));
  EXPECT_NE(why.find("accel.sigma.bias[1]"), std::string::npos) << why;
}

}  // namespace
}  // namespace imubench::calib
