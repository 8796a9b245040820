// The online engine's pieces that need no bench: step statistics, the acceptance verdict, the
// plan's calibration key.
#include "daemon/online_engine.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "daemon/run_calibration.h"
#include "nav/rotation.h"
#include "plans/plan.h"

namespace imubench::daemon {
namespace {

nav::ImuSample sample(double t, const Eigen::Vector3d& f, const Eigen::Vector3d& w, double dt) {
  nav::ImuSample s;
  s.t = t;
  s.dvel = f * dt;
  s.dtheta = w * dt;
  return s;
}

TEST(StepStats, HoldMeanAndPerSampleNoise) {
  StepStats st;
  st.kind = calib::SegmentKind::kStatic;
  const double dt = 0.005;
  // Specific force alternating +-a about its mean: per-sample sigma a (n/(n-1) aside).
  const double a = 2e-3;
  const int n = 1000;
  for (int k = 0; k < n; ++k) {
    const double sign = k % 2 == 0 ? 1.0 : -1.0;
    st.add(sample(dt * (k + 1), {0.1 + sign * a, 0.0, 9.8}, {0.0, 0.0, 7e-5}, dt), dt);
  }
  EXPECT_EQ(st.samples, static_cast<std::size_t>(n));
  EXPECT_NEAR(st.f_mean.x(), 0.1, 1e-12);
  EXPECT_NEAR(st.f_mean.z(), 9.8, 1e-12);
  const nlohmann::json j = st.toJson();
  const double noise = j["accel_noise_mps2"][0].get<double>();
  EXPECT_NEAR(noise, a * std::sqrt(n / (n - 1.0)), 1e-9);
  EXPECT_NEAR(j["rate_deg_h"][2].get<double>(), 7e-5 / (kDegToRad / 3600.0), 1e-6);
  EXPECT_NEAR(j["duration_s"].get<double>(), dt * (n - 1), 1e-12);
}

TEST(StepStats, RunTurnedAngle) {
  StepStats st;
  st.kind = calib::SegmentKind::kRotate;
  const double dt = 0.01;
  for (int k = 0; k < 1800; ++k)
    st.add(sample(dt * (k + 1), {0, 0, 9.8}, {0, 0, 0.1 * kDegToRad / dt}, dt), dt);
  EXPECT_NEAR(st.toJson()["turned_deg"][2].get<double>(), 180.0, 1e-9);
}

RunCalibration calibrated(double gyro_bias_z, bool gyro_bias_z_observable) {
  RunCalibration c;
  c.status = Status::Ok();
  c.coefficients.values.sensors.gyro.bias = {1e-8, -1e-8, gyro_bias_z};
  c.coefficients.values.sensors.accel.scale = {1.0002, 1.0, 0.9999};
  for (const char* n : {"gyro.bias.x", "gyro.bias.y", "gyro.bias.z", "accel.scale.x",
                        "accel.scale.y", "accel.scale.z"}) {
    c.coefficients.uncertainty[n].sigma = 1e-10;
  }
  if (!gyro_bias_z_observable) c.coefficients.setUnobservable("gyro.bias.z");
  return c;
}

std::vector<AcceptanceLimit> limits() {
  return {{"gyro.bias", 0.01 * kDegToRad / 3600.0, "0.01 deg/h"},
          {"accel.scale", 300e-6, "300 ppm"}};
}

TEST(AcceptanceVerdict, PassWhenEveryLimitedParameterIsWithin) {
  const nlohmann::json v = acceptanceVerdict(calibrated(2e-8, true), limits());
  EXPECT_EQ(v["pass"], true) << v.dump(2);
  EXPECT_EQ(v["rows"].size(), 6u);  // gyro.bias x, y, z and accel.scale x, y, z
}

TEST(AcceptanceVerdict, FailOutsideAndWhenNotDetermined) {
  // 0.05 deg/h is outside 0.01 deg/h.
  nlohmann::json v = acceptanceVerdict(calibrated(0.05 * kDegToRad / 3600.0, true), limits());
  EXPECT_EQ(v["pass"], false);
  bool found = false;
  for (const auto& row : v["rows"]) {
    if (row["parameter"] == "gyro.bias.z") {
      found = true;
      EXPECT_EQ(row["pass"], false);
      EXPECT_NEAR(row["value"].get<double>(), 0.05, 1e-12);
    }
  }
  EXPECT_TRUE(found);
  // Held at its start value: never passes.
  v = acceptanceVerdict(calibrated(0.0, false), limits());
  EXPECT_EQ(v["pass"], false);
  // A failed calibration fails every limit; no limits: no verdict.
  RunCalibration failed;
  failed.status = Status::Error("too little data");
  EXPECT_EQ(acceptanceVerdict(failed, limits())["pass"], false);
  EXPECT_TRUE(acceptanceVerdict(calibrated(0.0, true), {})["pass"].is_null());
}

std::optional<plans::Plan> parsePlanText(const std::string& plan_keys, io::Diagnostics& diag) {
  const std::string text = "[plan]\nname = \"p\"\n" + plan_keys +
                           "\n[table]\nkind = \"two-axis\"\n[[step]]\ntype = \"hold\"\n"
                           "duration = \"10 s\"\n";
  return plans::parsePlan(text, "p.toml", diag);
}

TEST(PlanCalibrationKey, ParsedAndChecked) {
  io::Diagnostics ok("p.toml");
  auto p = parsePlanText("calibration = \"pipeline\"\ndirect_plan = \"direct_two_axis\"", ok);
  ASSERT_TRUE(p.has_value()) << ok.str();
  EXPECT_EQ(p->calibration, plans::CalibrationMethod::kPipeline);
  EXPECT_EQ(p->direct_plan, "direct_two_axis");
  io::Diagnostics none("p.toml");
  p = parsePlanText("", none);
  ASSERT_TRUE(p.has_value()) << none.str();
  EXPECT_EQ(p->calibration, plans::CalibrationMethod::kNone);

  io::Diagnostics missing("p.toml");
  EXPECT_FALSE(parsePlanText("calibration = \"pipeline\"", missing).has_value());
  EXPECT_NE(missing.str().find("needs direct_plan"), std::string::npos) << missing.str();
  io::Diagnostics unknown("p.toml");
  EXPECT_FALSE(parsePlanText("calibration = \"magic\"", unknown).has_value());
  EXPECT_NE(unknown.str().find("p.toml:3:"), std::string::npos) << unknown.str();
  io::Diagnostics stray("p.toml");
  EXPECT_FALSE(parsePlanText("calibration = \"direct\"\ndirect_plan = \"x\"", stray).has_value());
}

}  // namespace
}  // namespace imubench::daemon
