// A plan's predicted motion (plans/expand) and the virtual table executing the same commands
// at the same times (drivers/virtual_table) are one motion profile (calib/model/
// motion_profile.h): they agree sample for sample.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "calib/motion.h"
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

const char* const kMotionPlan = R"(
[plan]
name = "profile"
[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
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
  const plans::ExpandResult ex = plans::expand(parseValid(kMotionPlan));
  ASSERT_TRUE(ex.ok) << ex.error;
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

}  // namespace
}  // namespace imubench::drivers
