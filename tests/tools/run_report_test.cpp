// The `imubench run` per-rotation summary: gyro angles and specific force around rotations.
#include <gtest/gtest.h>

#include "tools/cli_run_report.h"

namespace imubench::tools {
namespace {

// 100 Hz: static 0..10 s (f = +g z), rotate about z by +180 deg over 10..20 s at 18 deg/s,
// static 20..30 s (f = +g z, plus a known x offset to tell before from after).
nav::ImuSamples syntheticImu() {
  nav::ImuSamples imu;
  const double dt = 0.01;
  for (int k = 1; k <= 3000; ++k) {
    nav::ImuSample s;
    s.t = k * dt;
    const double mid = s.t - 0.5 * dt;
    const bool rotating = mid > 10.0 && mid < 20.0;
    s.dtheta = rotating ? Vec3(0.0, 0.0, 18.0 * kDegToRad * dt) : Vec3::Zero();
    s.dvel = Vec3(mid > 20.0 ? 0.01 : 0.0, 0.0, 9.81) * dt;
    imu.push_back(s);
  }
  return imu;
}

std::vector<calib::Segment> segments() {
  calib::Segment a, b, c;
  a.t0 = 0.0;
  a.t1 = 10.0;
  a.kind = calib::SegmentKind::kStatic;
  b.t0 = 10.0;
  b.t1 = 20.0;
  b.kind = calib::SegmentKind::kRotate;
  b.axis = 1;
  b.angle = kPi;
  b.label = "z_half";
  c.t0 = 20.0;
  c.t1 = 30.0;
  c.kind = calib::SegmentKind::kStatic;
  return {a, b, c};
}

TEST(RunReport, IntegratesGyroAndAveragesSpecificForce) {
  const auto runs = summarizeRotations(segments(), syntheticImu());
  ASSERT_EQ(runs.size(), 1u);
  const auto& r = runs[0];
  EXPECT_EQ(r.label, "z_half");
  EXPECT_EQ(r.axis, 1);
  EXPECT_DOUBLE_EQ(r.duration_s, 10.0);
  EXPECT_NEAR(r.gyro_angle_rad.z() * kRadToDeg, 180.0, 1e-9);
  EXPECT_NEAR(r.gyro_angle_rad.x(), 0.0, 1e-15);
  ASSERT_TRUE(r.f_before.has_value());
  ASSERT_TRUE(r.f_after.has_value());
  EXPECT_NEAR(r.f_before->z(), 9.81, 1e-12);
  EXPECT_NEAR(r.f_before->x(), 0.0, 1e-15);
  EXPECT_NEAR(r.f_after->x(), 0.01, 1e-12);
  const std::string table = formatRotationTable(runs, {"outer", "inner"});
  EXPECT_NE(table.find("z_half"), std::string::npos);
  EXPECT_NE(table.find("inner"), std::string::npos);
  EXPECT_NE(table.find("+180.00"), std::string::npos) << table;
}

TEST(RunReport, MissingStaticNeighboursGiveNoForce) {
  auto segs = segments();
  segs.erase(segs.begin());
  const auto runs = summarizeRotations(segs, syntheticImu());
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_FALSE(runs[0].f_before.has_value());
  EXPECT_TRUE(runs[0].f_after.has_value());
  EXPECT_NE(formatRotationTable(runs, {"outer", "inner"}).find(" -"), std::string::npos);
}

TEST(RunReport, MeanSpecificForceNeedsSamplesInside) {
  const auto imu = syntheticImu();
  EXPECT_FALSE(meanSpecificForce(imu, 5.0, 5.005).has_value());
  const auto f = meanSpecificForce(imu, 1.0, 2.0);
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR(f->z(), 9.81, 1e-12);
}

}  // namespace
}  // namespace imubench::tools
