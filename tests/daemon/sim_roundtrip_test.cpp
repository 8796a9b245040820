// Simulated bench run -> imubench-csv/1 -> read back: identical samples, bit for bit. And the
// truth/coefficient JSON files.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "calib/simulator.h"
#include "io/recording.h"
#include "io/sim_recording.h"
#include "io/truth_file.h"
#include "plans/expand.h"
#include "tests/daemon/recording_fixtures.h"

namespace imubench::daemon {
namespace {

namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() /
                     ("imubench-simrt-" + name + "-" +
                      std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::remove_all(p);
  return p;
}

using testing::imuMismatches;
using testing::sameBits;

// Two-axis: hold 3 s, inner +180 deg at 30 deg/s, hold 3 s, outer -90 deg, hold 3 s.
calib::Motion shortMotion() {
  calib::Motion m;
  m.kind = calib::TableKind::kTwoAxis;
  m.axes.resize(2);
  m.axes[0].append({0.0, 0.0, 0.0, 0.0});
  m.axes[1].append({0.0, 0.0, 0.0, 0.0});
  double t = 3.0;
  calib::Segment s0{0.0, t, calib::SegmentKind::kStatic, "hold-1", true, -1, 0.0};
  const double d1 =
      plans::appendProfile(m.axes[1], t, 0.0, kPi, 30.0 * kDegToRad, 20.0 * kDegToRad);
  calib::Segment s1{t, t + d1, calib::SegmentKind::kRotate, "inner+180", true, 1, kPi};
  t += d1;
  calib::Segment s2{t, t + 3.0, calib::SegmentKind::kStatic, "hold-2", true, -1, 0.0};
  t += 3.0;
  const double d2 =
      plans::appendProfile(m.axes[0], t, 0.0, -kPi / 2, 30.0 * kDegToRad, 20.0 * kDegToRad);
  calib::Segment s3{t, t + d2, calib::SegmentKind::kRotate, "outer-90", true, 0, -kPi / 2};
  t += d2;
  calib::Segment s4{t, t + 3.0, calib::SegmentKind::kStatic, "hold-3", true, -1, 0.0};
  t += 3.0;
  m.segments = {s0, s1, s2, s3, s4};
  m.duration = t;
  return m;
}

TEST(SimulatedRecording, WriteReadIsBitExact) {
  calib::SimulatorInput in;
  in.motion = shortMotion();
  in.world.site.latitude_rad = 55.75 * kDegToRad;
  in.world.site.height_m = 150.0;
  in.world.truth.sensors.accel.bias = Vec3(5e-4, -3e-4, 2e-4);
  in.world.truth.sensors.gyro.scale = Vec3(1.00002, 0.99998, 1.00001);
  in.world.noise = calib::NoiseModel::navigationGrade();
  calib::SimOptions opt;
  opt.imu_rate_hz = 400.0;
  opt.seed = 12345;
  const calib::Simulation sim = calib::simulate(in, opt);
  ASSERT_TRUE(sim.status.ok) << sim.status.message;
  ASSERT_GT(sim.imu.size(), 4000u);

  io::RecordingIdentity id;
  id.imu_rate_hz = opt.imu_rate_hz;
  const io::Recording rec = io::recordingFromSimulation(sim, in.world.site, id);
  const fs::path dir = freshDir("bitexact");
  ASSERT_TRUE(io::writeRecording(dir.string(), rec).ok);
  const auto back = io::readRecording(dir.string());
  ASSERT_TRUE(back.status.ok) << back.status.message;
  const io::Recording& r = back.value;

  ASSERT_EQ(r.imu.size(), sim.imu.size());
  EXPECT_EQ(imuMismatches(sim.imu, r.imu), 0u);
  ASSERT_EQ(r.table.size(), rec.table.size());
  for (size_t i = 0; i < rec.table.size(); ++i) {
    EXPECT_TRUE(sameBits(r.table[i].t, rec.table[i].t));
    EXPECT_TRUE(sameBits(r.table[i].angles_deg[0], rec.table[i].angles_deg[0]));
    EXPECT_TRUE(sameBits(r.table[i].angles_deg[1], rec.table[i].angles_deg[1]));
  }
  ASSERT_EQ(r.segments.size(), sim.segments.size());
  for (size_t i = 0; i < r.segments.size(); ++i) {
    EXPECT_EQ(r.segments[i].label, sim.segments[i].label);
    EXPECT_EQ(r.segments[i].kind, sim.segments[i].kind);
    EXPECT_TRUE(sameBits(r.segments[i].t0, sim.segments[i].t0));
    EXPECT_TRUE(sameBits(r.segments[i].t1, sim.segments[i].t1));
  }
  // Rotate axes/angles recovered from the encoder record.
  EXPECT_EQ(r.segments[1].axis, 1);
  EXPECT_NEAR(r.segments[1].angle, kPi, 1e-9);
  EXPECT_EQ(r.segments[3].axis, 0);
  EXPECT_NEAR(r.segments[3].angle, -kPi / 2, 1e-9);
  EXPECT_NEAR(r.latitude_deg, 55.75, 1e-12);
  fs::remove_all(dir);
}

TEST(SimulatedRecording, DerivedSegmentsMatchThePlanWhenSegmentsFileIsMissing) {
  calib::SimulatorInput in;
  in.motion = shortMotion();
  calib::SimOptions opt;
  opt.imu_rate_hz = 100.0;
  const calib::Simulation sim = calib::simulate(in, opt);
  ASSERT_TRUE(sim.status.ok) << sim.status.message;
  io::Recording rec = io::recordingFromSimulation(sim, in.world.site, io::RecordingIdentity{});
  rec.segments.clear();
  const fs::path dir = freshDir("derived");
  ASSERT_TRUE(io::writeRecording(dir.string(), rec).ok);
  const auto back = io::readRecording(dir.string());
  ASSERT_TRUE(back.status.ok) << back.status.message;
  const auto& segs = back.value.segments;
  ASSERT_EQ(segs.size(), 5u);
  const calib::SegmentKind kinds[] = {calib::SegmentKind::kStatic, calib::SegmentKind::kRotate,
                                      calib::SegmentKind::kStatic, calib::SegmentKind::kRotate,
                                      calib::SegmentKind::kStatic};
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(segs[i].kind, kinds[i]) << i;
    // Boundaries within one encoder sample (10 ms) plus the slow start of the ramp.
    EXPECT_NEAR(segs[i].t0, in.motion.segments[i].t0, 0.05) << i;
  }
  EXPECT_EQ(segs[1].axis, 1);
  EXPECT_NEAR(segs[1].angle, kPi, 1e-9);
  EXPECT_EQ(segs[3].axis, 0);
  EXPECT_NEAR(segs[3].angle, -kPi / 2, 1e-9);
  fs::remove_all(dir);
}

TEST(TruthFile, RoundTripKeepsEveryCoefficient) {
  calib::BenchTruth t;
  t.sensors.accel.bias = Vec3(1.0 / 3.0, -2e-4, 7e-5);
  t.sensors.gyro.mis.xy = 1.2345678901234567e-5;
  t.table.base_tilt = Vec2(4.8e-5, -9.7e-5);
  const fs::path dir = freshDir("truth");
  fs::create_directories(dir);
  const std::string path = (dir / "truth.json").string();
  ASSERT_TRUE(io::writeTruthFile(path, t).ok);
  const auto r = io::readTruthFile(path);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const auto a = calib::flatValues(t);
  const auto b = calib::flatValues(r.value);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(sameBits(a[i], b[i])) << calib::flatNames(t)[i];
  fs::remove_all(dir);
}

TEST(TruthFile, ErrorsNameTheFile) {
  const fs::path dir = freshDir("truthbad");
  fs::create_directories(dir);
  const std::string syntax = (dir / "syntax.json").string();
  std::ofstream(syntax) << "{\n  \"accel\": {\n    \"bias\": [1, 2,\n  }\n}\n";
  auto r = io::readTruthFile(syntax);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(syntax + ":4: JSON syntax error", 0), 0u) << r.status.message;

  const std::string bad = (dir / "bad.json").string();
  std::ofstream(bad) << R"({"accel": {"bias": [1, 2, "x"]}})";
  r = io::readTruthFile(bad);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(bad + ": accel", 0), 0u) << r.status.message;

  r = io::readTruthFile((dir / "missing.json").string());
  ASSERT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("missing file"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace imubench::daemon
