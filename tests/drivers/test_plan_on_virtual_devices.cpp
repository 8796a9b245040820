// A plan's predicted motion (plans/expand) and the virtual table executing the same commands
// at the same times (drivers/virtual_table) are one motion profile (calib/model/
// motion_profile.h): they agree sample for sample. Likewise the plan's predicted temperature
// and the virtual chamber are one thermal model (calib/model/thermal_lag.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>

#include "calib/model/motion.h"
#include "calib/model/thermal_lag.h"
#include "drivers/virtual_chamber.h"
#include "drivers/virtual_table.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "virtual_bench_fixture.h"

namespace imubench::drivers {
namespace {

// The plan's profile limits (below the device file's 300 deg/s, 100 deg/s^2, so they apply).
constexpr double kRate = 20 * kDegToRad;
constexpr double kAccel = 10 * kDegToRad;
constexpr double kSpin = -15 * kDegToRad;  // the rate step's signed rate
constexpr double kSpinAccel = 8 * kDegToRad;

// The plans' header: a two-axis table at the limits above.
constexpr std::string_view kTableHeader = R"(
[plan]
name = "on_virtual_devices"
[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
)";

std::string motionPlan() {
  return std::string(kTableHeader) + R"(
[[step]]
type = "hold"
duration = "2 s"
[[step]]
type = "move"
outer = "270 deg"
inner = "3 deg"
[[step]]
type = "rotate"
axis = "inner"
angle = "-200 deg"
[[step]]
type = "hold"
duration = "1.5 s"
[[step]]
type = "rate"
axis = "outer"
rate = "15 deg/s"
direction = "-"
accel = "8 deg/s^2"
duration = "7 s"
)";
}

plans::Plan parseValid(const std::string& text) {
  io::Diagnostics diag("profile.toml");
  auto plan = plans::parsePlan(text, "profile.toml", diag);
  EXPECT_TRUE(plan.has_value()) << diag.str();
  if (!plan) return {};
  EXPECT_TRUE(plans::validatePlan(*plan, diag)) << diag.str();
  return *plan;
}

// Start of the ramp back to rest of a rate step on `axis`: the phase after its cruise.
double rateStopTime(const calib::AxisTrajectory& axis, const calib::Segment& seg) {
  for (const calib::AxisPhase& p : axis.phases()) {
    if (p.t0 > seg.t0 && p.t0 < seg.t1 && p.accel != 0.0 && p.rate0 != 0.0) return p.t0;
  }
  ADD_FAILURE() << "no ramp down in the rate step";
  return seg.t1;
}

// Commands the plan's segments to the table at the planned times, as the plan runner would.
void drive(VirtualTable& table, const calib::Motion& m) {
  std::string why;
  for (const calib::Segment& seg : m.segments) {
    if (seg.kind == calib::SegmentKind::kMove) {
      for (int i = 0; i < 2; ++i) {
        const double end = m.axes[static_cast<size_t>(i)].at(seg.t1).angle;
        if (end == m.axes[static_cast<size_t>(i)].at(seg.t0).angle) continue;
        EXPECT_TRUE(table.moveTo(seg.t0, i, end, &why)) << why;
      }
    } else if (seg.kind == calib::SegmentKind::kRotate && seg.axis == 1) {
      EXPECT_TRUE(table.rotateBy(seg.t0, 1, seg.angle, &why)) << why;
    } else if (seg.kind == calib::SegmentKind::kRotate) {  // the rate step
      EXPECT_TRUE(table.setMode(seg.t0, 0, AxisMode::kRate, &why)) << why;
      EXPECT_TRUE(table.setAccelLimit(0, kSpinAccel, &why)) << why;
      EXPECT_TRUE(table.setRate(seg.t0, 0, kSpin, &why)) << why;
      EXPECT_TRUE(table.setRate(rateStopTime(m.axes[0], seg), 0, 0.0, &why)) << why;
    }
  }
}

TEST(PlanOnVirtualTable, MotionEqualsThePlanExpandersProfileSampleForSample) {
  const plans::ExpandResult ex = plans::expand(parseValid(motionPlan()));
  ASSERT_TRUE(ex.status.ok) << ex.status.message;
  const calib::Motion& m = ex.motion;
  ASSERT_EQ(m.segments.size(), 5u);  // hold, move, rotate, hold, rate

  const TableDeviceSpec spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  ASSERT_GT(spec.limits.max_rate, kRate);
  ASSERT_GT(spec.limits.max_accel, kAccel);
  VirtualTable table(spec);
  std::string why;
  table.interlockClose(0.0, &why);
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(table.setMode(0.0, i, AxisMode::kPosition, &why)) << why;
    ASSERT_TRUE(table.setRateLimit(i, kRate, &why)) << why;
    ASSERT_TRUE(table.setAccelLimit(i, kAccel, &why)) << why;
  }
  drive(table, m);
  const calib::Motion& done = table.motion(m.duration + 1.0);

  // Sample both every 1 ms and at every phase start of either (the profile's corners).
  std::vector<double> times;
  for (double t = 0.0; t <= m.duration + 0.5; t += 1e-3) times.push_back(t);
  for (const calib::Motion* mm : {&m, &done}) {
    for (const auto& axis : mm->axes) {
      for (const auto& p : axis.phases()) times.push_back(p.t0);
    }
  }
  int checked = 0;
  for (int i = 0; i < 2; ++i) {
    const auto& want = m.axes[static_cast<size_t>(i)];
    const auto& got = done.axes[static_cast<size_t>(i)];
    for (double t : times) {
      const calib::AxisState a = want.at(t), b = got.at(t);
      ASSERT_NEAR(b.angle, a.angle, 1e-12) << "axis " << i << " t " << t;
      ASSERT_NEAR(b.rate, a.rate, 1e-12) << "axis " << i << " t " << t;
      ASSERT_NEAR(b.accel, a.accel, 1e-12) << "axis " << i << " t " << t;
      ++checked;
    }
  }
  EXPECT_GT(checked, 2 * 20000);
  // The motion really moved: the outer axis turned the short way (-90 deg) and then spun.
  EXPECT_NEAR(m.axes[0].at(m.segments[2].t0).angle, -kPi / 2, 1e-12);
  EXPECT_LT(m.axes[0].at(m.duration).angle, -kPi / 2 - 7.0 * 15 * kDegToRad * 0.99);
  EXPECT_NEAR(m.axes[1].at(m.duration).angle, -197 * kDegToRad, 1e-12);
}

std::string chamberPlan() {
  return std::string(kTableHeader) + R"(
[chamber]
min_temp = "-40 degC"
max_temp = "85 degC"
max_ramp = "4 degC/min"
initial = "20 degC"
[[step]]
type = "chamber"
setpoint = "40 degC"
soak = "5 min"
[[step]]
type = "hold"
duration = "100 s"
[[step]]
type = "chamber"
setpoint = "-10 degC"
ramp = "3 degC/min"
soak = "2 min"
[[step]]
type = "chamber"
setpoint = "-5 degC"
soak = "15 min"
)";
}

// The chamber steps' ramp rates, degC/s, in order.
std::vector<double> chamberRamps(const plans::Plan& plan) {
  std::vector<double> out;
  for (const plans::Step& s : plan.steps) {
    if (s.type != plans::StepType::kChamber) continue;
    out.push_back(s.ramp ? s.ramp->value : plan.chamber->max_ramp.value);
  }
  return out;
}

TEST(PlanOnVirtualChamber, PredictedTemperatureEqualsTheVirtualChambers) {
  const plans::Plan plan = parseValid(chamberPlan());
  const ChamberDeviceSpec spec = testing::chamberSpec("watlow-f4-style.toml");
  ASSERT_NEAR(spec.time_constant_s, 180.0, 1e-9);
  plans::ExpandOptions options;
  options.thermal.chamber_tau_s = spec.time_constant_s;
  const plans::ExpandResult ex = plans::expand(plan, options);
  ASSERT_TRUE(ex.status.ok) << ex.status.message;
  const calib::Motion& m = ex.motion;

  // The chamber's commands at the planned times: each soak's ramp rate and setpoint.
  struct Command {
    double t, ramp, setpoint;
  };
  std::vector<Command> commands;
  const std::vector<double> ramps = chamberRamps(plan);
  for (const calib::Segment& seg : m.segments) {
    if (seg.kind != calib::SegmentKind::kSoak) continue;
    ASSERT_LT(commands.size(), ramps.size());
    commands.push_back({seg.t0, ramps[commands.size()], seg.setpoint_c});
  }
  ASSERT_EQ(commands.size(), 3u);
  EXPECT_EQ(commands[0].setpoint, 40.0);
  EXPECT_EQ(commands[1].setpoint, -10.0);

  // Run the chamber through the plan; every predicted knot is its temperature at that time.
  VirtualChamber chamber(spec, 20.0, 0.0);
  chamber.run(0.0, true);
  ASSERT_GT(m.temperature.size(), 500u) << "knots while the lag settles";
  size_t next = 0;
  for (const calib::TemperatureKnot& knot : m.temperature) {
    for (; next < commands.size() && commands[next].t <= knot.t; ++next) {
      chamber.setRampRate(commands[next].t, commands[next].ramp);
      chamber.setSetpoint(commands[next].t, commands[next].setpoint);
    }
    ASSERT_NEAR(chamber.temperature(knot.t), knot.temp_c, 1e-9) << "t " << knot.t;
  }
  EXPECT_EQ(next, commands.size());
  // Between knots the prediction interpolates the chamber's history closely.
  for (const calib::TemperatureKnot& knot : chamber.history(m.duration)) {
    EXPECT_NEAR(m.temperatureAt(knot.t), knot.temp_c, 2e-3) << "t " << knot.t;
  }
  // The air lags the ramp: at the end of the 20 -> 40 degC ramp (300 s at 4 degC/min) it is
  // a time constant's worth of ramp (12 degC) behind, less the start-up transient.
  const double lag = (4.0 / 60.0) * 180.0 * (1.0 - std::exp(-300.0 / 180.0));
  EXPECT_NEAR(m.temperatureAt(300.0), 40.0 - lag, 1e-3);
}

// The thermal model's closed form against a fine numerical integration of its equations
// (program ramp, air lag tau1, sensor lag tau2), also with equal time constants.
calib::model::ThermalState integrate(calib::model::ThermalState s, double goal, double ramp,
                                     const calib::model::ThermalLag& lag, double h) {
  const int n = 200000;
  const double dt = h / n;
  for (int i = 0; i < n; ++i) {  // midpoint rule on the two lags, exact program
    const double step = ramp * dt;
    const double next = s.program_c + std::clamp(goal - s.program_c, -step, step);
    const double u = 0.5 * (s.program_c + next);
    const double x_mid = s.air_c + 0.5 * dt * (u - s.air_c) / lag.chamber_tau_s;
    const double y_mid = s.sensor_c + 0.5 * dt * (s.air_c - s.sensor_c) / lag.sensor_tau_s;
    s.air_c += dt * (u - x_mid) / lag.chamber_tau_s;
    s.sensor_c += dt * (x_mid - y_mid) / lag.sensor_tau_s;
    s.program_c = next;
  }
  return s;
}

TEST(ThermalModel, ClosedFormMatchesTheEquations) {
  for (const calib::model::ThermalLag lag :
       {calib::model::ThermalLag{120.0, 40.0}, calib::model::ThermalLag{60.0, 60.0}}) {
    const calib::model::ThermalState s0{20.0, 22.0, 25.0};
    // 600 s: a 500 s ramp (to 45 degC at 0.05 degC/s), then 100 s on the goal.
    const auto exact = calib::model::advanceThermal(s0, 45.0, 0.05, lag, 600.0);
    const auto numeric = integrate(s0, 45.0, 0.05, lag, 600.0);
    EXPECT_EQ(exact.program_c, 45.0);
    EXPECT_NEAR(exact.air_c, numeric.air_c, 1e-6) << lag.sensor_tau_s;
    EXPECT_NEAR(exact.sensor_c, numeric.sensor_c, 1e-6) << lag.sensor_tau_s;
    EXPECT_LT(exact.sensor_c, exact.air_c);  // the IMU lags the air
    // Composition: two steps equal one.
    const auto half = calib::model::advanceThermal(s0, 45.0, 0.05, lag, 250.0);
    const auto two = calib::model::advanceThermal(half, 45.0, 0.05, lag, 350.0);
    EXPECT_NEAR(two.sensor_c, exact.sensor_c, 1e-10);
  }
}

}  // namespace
}  // namespace imubench::drivers
