// Issue 16 item 5: one direct calibration per temperature point of a thermal run
// (daemon/thermal_points.h), on a simulated two-point thermal plan whose body is the bundled
// direct two-axis plan.
#include "daemon/thermal_points.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "calib/bench_truth.h"
#include "calib/simulator.h"
#include "io/sim_recording.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace imubench::daemon {
namespace {

void replaceOnce(std::string& s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
}

// thermal_two_axis.toml at -10 and +30 degC only, heating, ramps at 10 degC/min.
calib::Motion twoPointMotion() {
  const std::string path =
      std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/thermal_two_axis.toml";
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  replaceOnce(text, R"(["-40 degC", "-15 degC", "10 degC", "35 degC", "60 degC"])",
              R"(["-10 degC", "30 degC"])");
  replaceOnce(text, R"(legs = "heat-cool")", R"(legs = "heat")");
  replaceOnce(text, R"(max_ramp = "1 degC/min")", R"(max_ramp = "10 degC/min")");
  replaceOnce(text, R"(ramp = "1 degC/min")", R"(ramp = "10 degC/min")");
  io::Diagnostics diag("two_point.toml");
  auto plan = plans::parsePlan(text, "two_point.toml", diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  const plans::ExpandResult e = plans::expand(*plan);
  EXPECT_TRUE(e.status.ok) << e.status.message;
  return e.motion;
}

constexpr double kAccelBiasX = 5e-4, kGyroScaleY = 1.0002;

io::Recording twoPointRecording() {
  calib::SimulatorInput in;
  in.motion = twoPointMotion();
  in.world.site.latitude_rad = 55.75 * kDegToRad;
  in.world.site.height_m = 150.0;
  in.world.noise = calib::NoiseModel::navigationGrade();
  in.world.truth.sensors.accel.bias = Vec3(kAccelBiasX, -3e-4, 2e-4);
  in.world.truth.sensors.gyro.scale = Vec3(1.0001, kGyroScaleY, 0.9999);
  calib::SimOptions opt;
  opt.imu_rate_hz = 50.0;
  opt.table_rate_hz = 50.0;
  opt.seed = 16;
  const calib::Simulation sim = calib::simulate(in, opt);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;
  io::RecordingIdentity id;
  id.imu_serial = "SIM-THERMAL";
  id.imu_rate_hz = opt.imu_rate_hz;
  return io::recordingFromSimulation(sim, in.world.site, id);
}

TEST(ThermalPoints, EachPointIsCalibratedAtItsOwnTemperature) {
  const io::Recording rec = twoPointRecording();
  const std::vector<PointCalibration> points = calibrateTemperaturePoints(rec, std::nullopt);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].label, "T-10C/soak");
  EXPECT_EQ(points[1].label, "T30C/soak");
  const double setpoints[] = {-10.0, 30.0};
  for (int k = 0; k < 2; ++k) {
    const PointCalibration& p = points[k];
    ASSERT_TRUE(p.status.ok) << p.label << ": " << p.status.message;
    EXPECT_EQ(p.temperature_source, "imu");
    EXPECT_NEAR(p.temperature_c, setpoints[k], 0.5) << p.label;
    EXPECT_GT(p.segments, 10) << p.label;
    EXPECT_GE(p.t0, k == 0 ? 0.0 : points[0].t1) << "the points' spans do not overlap";
    calib::CoefficientReport c;
    std::string why;
    ASSERT_TRUE(calib::fromJson(p.coefficients, &c, &why)) << why;
    EXPECT_NEAR(c.values.sensors.accel.bias.x(), kAccelBiasX, 5e-5) << p.label;
    EXPECT_NEAR(c.values.sensors.gyro.scale.y(), kGyroScaleY, 5e-5) << p.label;
    const nlohmann::json j = pointJson(p);
    EXPECT_EQ(j.at("point"), p.label);
    EXPECT_TRUE(j.contains("coefficients"));
  }
}

TEST(ThermalPoints, ARunWithoutSoaksHasNoPoints) {
  io::Recording rec = twoPointRecording();
  for (calib::Segment& s : rec.segments) {
    if (s.kind == calib::SegmentKind::kSoak) s.kind = calib::SegmentKind::kStatic;
  }
  EXPECT_TRUE(calibrateTemperaturePoints(rec, std::nullopt).empty());
}

}  // namespace
}  // namespace imubench::daemon
