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
  c.fit = calib::FitStatus{};  // usable
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

// Issue 28 item 4: the calibration sees complete segments only. A gap between holds (a
// resume's) keeps every segment; a rotation next to a gap and a segment spanning one are left
// out, named; every sample stays.
TEST(CompleteSegments, GapsNextToRotationsOrInsideSegmentsLeaveThoseSegmentsOut) {
  io::Recording rec;
  for (int i = 1; i <= 1000; ++i) {  // 100 Hz, a 30 s gap after t = 5 s
    const double t = 0.01 * i + (i > 500 ? 30.0 : 0.0);
    rec.imu.push_back(sample(t, Eigen::Vector3d(0, 0, 9.8), Eigen::Vector3d::Zero(), 0.01));
  }
  auto seg = [](double t0, double t1, calib::SegmentKind kind, const char* label) {
    calib::Segment s;
    s.t0 = t0, s.t1 = t1, s.kind = kind, s.label = label;
    return s;
  };
  using K = calib::SegmentKind;
  rec.segments = {seg(0.5, 2.0, K::kStatic, "h1"), seg(2.0, 4.0, K::kRotate, "r1"),
                  seg(4.0, 4.5, K::kStatic, "h2"), seg(36.0, 38.0, K::kStatic, "h2"),
                  seg(38.0, 39.0, K::kRotate, "r2")};
  std::vector<std::string> notes;
  io::Recording kept = completeSegmentsOnly(rec, &notes);
  EXPECT_EQ(kept.segments.size(), 5u) << "holds on both sides of the gap: nothing touches it";
  EXPECT_TRUE(notes.empty());
  EXPECT_EQ(kept.imu.size(), 1000u);

  rec.segments.erase(rec.segments.begin() + 2);  // the old rule: r1 stored right before it
  rec.segments.push_back(seg(39.0, 40.0, K::kStatic, "h3"));
  rec.segments[2] = seg(36.0, 37.0, K::kRotate, "r_after_gap");
  rec.segments.insert(rec.segments.begin(), seg(0.1, 0.4, K::kStatic, "h0"));
  rec.segments.push_back(seg(4.9, 36.5, K::kStatic, "spanning"));
  kept = completeSegmentsOnly(rec, &notes);
  std::vector<std::string> labels;
  for (const auto& s : kept.segments) labels.push_back(s.label);
  // spanning, then r1 (nearest before), r_after_gap and r2 (nearest after, one by one)
  EXPECT_EQ(labels, (std::vector<std::string>{"h0", "h1", "h3"}));
  ASSERT_EQ(notes.size(), 4u);
  EXPECT_NE(notes[0].find("segment 'spanning'"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("spans the gap in the IMU data 5.000-35.010 s"), std::string::npos)
      << notes[0];
  EXPECT_EQ(kept.imu.size(), 1000u);
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

// An unusable fit (residuals above the noise) gets no verdict, whether its values are within
// the limits or outside them: the rows still show each value against its limit.
TEST(AcceptanceVerdict, NoVerdictOnAnUnusableFit) {
  for (const double bias : {2e-8, 0.05 * kDegToRad / 3600.0}) {
    RunCalibration c = calibrated(bias, true);
    c.fit.code = calib::FitStatusCode::kUnusable;
    c.fit.ok = false;
    c.fit.message = "normalised residual RMS 14.5 (limit 3)";
    c.fit.reasons = {c.fit.message};
    const nlohmann::json v = acceptanceVerdict(c, limits());
    EXPECT_TRUE(v["pass"].is_null()) << v.dump(2);
    EXPECT_EQ(v["usable"], false);
    EXPECT_EQ(v["rows"].size(), 6u);
    const std::string why = v["why"].get<std::string>();
    EXPECT_NE(why.find("the fit is unusable (normalised residual RMS 14.5"), std::string::npos)
        << why;
    EXPECT_NE(why.find(bias < 1e-7 ? "are within the limits" : "exceed the limits"),
              std::string::npos)
        << why;
  }
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
