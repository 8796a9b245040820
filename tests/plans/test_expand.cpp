// Expansion into calib::Motion: exact trapezoid / triangle profiles, shortest-way moves,
// segments, labels, recording flags, temperature knots.
#include <gtest/gtest.h>

#include <cmath>

#include "nav/rotation.h"
#include "plan_test_util.h"

namespace imubench::plans {
namespace {

using calib::AxisTrajectory;
using calib::SegmentKind;

// Checks a trajectory phase by phase: angle and rate continuous across phase boundaries,
// |rate| <= max_rate and |accel| <= max_accel everywhere (the rate is extremal at phase
// boundaries since each phase has constant acceleration).
void expectContinuousWithinLimits(const AxisTrajectory& axis, double max_rate, double max_accel) {
  const auto& p = axis.phases();
  for (size_t k = 0; k < p.size(); ++k) {
    EXPECT_LE(std::abs(p[k].rate0), max_rate * (1 + 1e-12)) << "phase " << k;
    EXPECT_LE(std::abs(p[k].accel), max_accel * (1 + 1e-12)) << "phase " << k;
    if (k + 1 < p.size()) {
      const double dt = p[k + 1].t0 - p[k].t0;
      ASSERT_GE(dt, 0.0);
      const double angle = p[k].angle0 + p[k].rate0 * dt + 0.5 * p[k].accel * dt * dt;
      const double rate = p[k].rate0 + p[k].accel * dt;
      EXPECT_NEAR(angle, p[k + 1].angle0, 1e-9) << "angle jump at phase " << k + 1;
      EXPECT_NEAR(rate, p[k + 1].rate0, 1e-12) << "rate jump at phase " << k + 1;
      EXPECT_LE(std::abs(rate), max_rate * (1 + 1e-12));
    }
  }
}

TEST(Profile, TrapezoidEndsExactlyOnTarget) {
  AxisTrajectory axis;
  axis.append({0.0, 0.3, 0.0, 0.0});
  const double vmax = 10 * kDegToRad, amax = 5 * kDegToRad;
  const double d = appendProfile(axis, 5.0, 0.3, kPi, vmax, amax);
  // 2 s ramps (10 deg each) + 16 s cruise.
  EXPECT_NEAR(d, 20.0, 1e-12);
  EXPECT_NEAR(profileDuration(kPi, vmax, amax), d, 1e-12);
  EXPECT_EQ(axis.phases().size(), 5u);
  EXPECT_EQ(axis.phases().back().angle0, 0.3 + kPi) << "exact, not approximately";
  EXPECT_EQ(axis.at(25.0).rate, 0.0);
  EXPECT_NEAR(axis.at(25.0 - 1e-9).angle, 0.3 + kPi, 1e-12);
  EXPECT_NEAR(axis.at(15.0).rate, vmax, 1e-15);              // cruising
  EXPECT_NEAR(axis.at(15.0).angle, 0.3 + kPi / 2.0, 1e-12);  // symmetric profile
  expectContinuousWithinLimits(axis, vmax, amax);
}

TEST(Profile, TriangleWhenTooShortToReachTheRate) {
  AxisTrajectory axis;
  axis.append({0.0, 0.0, 0.0, 0.0});
  const double vmax = 10 * kDegToRad, amax = 5 * kDegToRad;
  const double delta = -5 * kDegToRad;  // needs 20 deg to reach 10 deg/s
  const double d = appendProfile(axis, 0.0, 0.0, delta, vmax, amax);
  EXPECT_NEAR(d, 2.0, 1e-12);  // peak 5 deg/s after 1 s
  EXPECT_NEAR(profileDuration(delta, vmax, amax), d, 1e-12);
  EXPECT_EQ(axis.phases().size(), 4u);
  EXPECT_NEAR(axis.at(1.0).rate, -5 * kDegToRad, 1e-15);
  EXPECT_EQ(axis.phases().back().angle0, delta);
  expectContinuousWithinLimits(axis, vmax, amax);
}

TEST(Profile, ZeroTurnAddsNothing) {
  AxisTrajectory axis;
  EXPECT_EQ(appendProfile(axis, 0.0, 0.0, 0.0, 1.0, 1.0), 0.0);
  EXPECT_TRUE(axis.empty());
}

calib::Motion expandText(const std::string& text, const ExpandOptions& options = {}) {
  io::Diagnostics diag("e.toml");
  auto plan = parsePlan(text, "e.toml", diag);
  EXPECT_TRUE(plan) << diag.str();
  if (!plan) return {};
  EXPECT_TRUE(validatePlan(*plan, diag)) << diag.str();
  ExpandResult r = expand(*plan, options);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return r.motion;
}

TEST(Expand, MoveTakesTheShortestWayAndKeepsAnglesContinuous) {
  // outer 0 -> 270 deg is -90 deg the short way; inner 0 -> 30 deg. Both start together.
  const auto m = expandText(test::twoAxis(R"([[step]]
type = "move"
outer = "270 deg"
inner = "30 deg"
label = "both"
[[step]]
type = "rotate"
axis = "inner"
angle = "360 deg"
[[step]]
type = "move"
inner = "40 deg"
label = "single"
)"));
  ASSERT_EQ(m.segments.size(), 3u);
  const auto& both = m.segments[0];
  EXPECT_EQ(both.kind, SegmentKind::kMove);
  EXPECT_EQ(both.label, "both");
  EXPECT_EQ(both.axis, -1);
  const double t_outer = profileDuration(-kPi / 2, 20 * kDegToRad, 10 * kDegToRad);
  EXPECT_NEAR(both.t1 - both.t0, t_outer, 1e-12) << "the longer of the two profiles";
  EXPECT_NEAR(m.axes[0].at(both.t1).angle, -kPi / 2, 1e-15);
  EXPECT_NEAR(m.axes[1].at(both.t1).angle, 30 * kDegToRad, 1e-15);
  // inner is at 390 deg after the full turn; 40 deg is +10 deg away, and stays continuous.
  const auto& single = m.segments[2];
  EXPECT_EQ(single.axis, 1);
  EXPECT_NEAR(single.angle, 10 * kDegToRad, 1e-12);
  EXPECT_NEAR(m.axes[1].at(m.duration).angle, 400 * kDegToRad, 1e-12);
  for (const auto& axis : m.axes)
    expectContinuousWithinLimits(axis, 20 * kDegToRad, 10 * kDegToRad);
}

TEST(Expand, RateRunExactTurns) {
  const auto m = expandText(R"(
[table]
kind = "two-axis"
max_rate = "50 deg/s"
max_accel = "20 deg/s^2"
[[step]]
type = "rate"
axis = "inner"
rate = "30 deg/s"
direction = "-"
duration = "33 s"
accel = "10 deg/s^2"
label = "spin"
)");
  ASSERT_EQ(m.segments.size(), 1u);
  const auto& s = m.segments[0];
  EXPECT_EQ(s.kind, SegmentKind::kRotate);
  EXPECT_EQ(s.axis, 1);
  // 3 s ramps + 33 s at 30 deg/s: exactly 3 turns backwards.
  EXPECT_NEAR(s.angle, -3 * 2 * kPi, 1e-12);
  EXPECT_NEAR(s.t1 - s.t0, 39.0, 1e-12);
  EXPECT_NEAR(m.axes[1].at(20.0).rate, -30 * kDegToRad, 1e-15);
  EXPECT_NEAR(m.axes[1].at(s.t1).angle, -6 * kPi, 1e-12);
  expectContinuousWithinLimits(m.axes[1], 30 * kDegToRad, 10 * kDegToRad);
}

TEST(Expand, RepeatLabelsRecordingAndTemperature) {
  const auto m = expandText(test::twoAxis(R"(
[chamber]
min_temp = "-40 degC"
max_temp = "70 degC"
max_ramp = "2 degC/min"
initial = "20 degC"

[[step]]
type = "record"
state = "off"

[[step]]
type = "chamber"
setpoint = "40 degC"
soak = "5 min"
label = "warm"

[[step]]
type = "record"
state = "on"

[[step]]
type = "repeat"
count = 2
label = "loop"
  [[step.steps]]
  type = "hold"
  duration = "10 s"
  [[step.steps]]
  type = "repeat"
  count = 1
    [[step.steps.steps]]
    type = "rotate"
    axis = "inner"
    angle = "45 deg"
    label = "turn"
)"));
  ASSERT_EQ(m.segments.size(), 5u);
  EXPECT_EQ(m.segments[0].kind, SegmentKind::kSoak);
  EXPECT_EQ(m.segments[0].label, "warm");
  EXPECT_FALSE(m.segments[0].recording);
  // 20 -> 40 degC at 2 degC/min: 10 min ramp, then a 5 min soak.
  EXPECT_NEAR(m.segments[0].t1, 900.0, 1e-9);
  EXPECT_NEAR(m.temperatureAt(300.0), 30.0, 1e-12);
  EXPECT_NEAR(m.temperatureAt(700.0), 40.0, 1e-12);
  EXPECT_NEAR(m.temperatureAt(m.duration), 40.0, 1e-12);
  EXPECT_EQ(m.segments[1].label, "loop#1/hold");
  EXPECT_EQ(m.segments[2].label, "loop#1/repeat/turn");
  EXPECT_EQ(m.segments[3].label, "loop#2/hold");
  EXPECT_EQ(m.segments[4].label, "loop#2/repeat/turn");
  for (size_t k = 1; k < m.segments.size(); ++k) {
    EXPECT_TRUE(m.segments[k].recording);
    EXPECT_NEAR(m.segments[k].t0, m.segments[k - 1].t1, 1e-9);
  }
  EXPECT_NEAR(m.axes[1].at(m.duration).angle, kPi / 2, 1e-12);
}

TEST(Expand, InitialAnglesOption) {
  ExpandOptions o;
  o.initial_angles = {kPi / 2, 0.0};
  const auto m = expandText(test::twoAxis("[[step]]\ntype = \"move\"\nouter = \"0 deg\"\n"), o);
  ASSERT_EQ(m.segments.size(), 1u);
  EXPECT_NEAR(m.segments[0].angle, -kPi / 2, 1e-15);
  EXPECT_EQ(m.axes[0].at(m.duration).angle, 0.0);

  io::Diagnostics diag("e.toml");
  auto plan =
      parsePlan(test::twoAxis("[[step]]\ntype = \"hold\"\nduration = \"1 s\"\n"), "e.toml", diag);
  ASSERT_TRUE(plan);
  o.initial_angles = {0.0};
  const ExpandResult r = expand(*plan, o);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("one entry per axis"), std::string::npos);
}

TEST(Expand, UnvalidatedUnknownAxisIsAnErrorNotACrash) {
  io::Diagnostics diag("e.toml");
  auto plan =
      parsePlan(test::twoAxis("[[step]]\ntype = \"move\"\nmiddle = \"10 deg\"\n"), "e.toml", diag);
  ASSERT_TRUE(plan) << diag.str();  // the parser accepts axis names; the validator refuses
  const ExpandResult r = expand(*plan);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("unknown axis \"middle\""), std::string::npos)
      << r.status.message;
}

}  // namespace
}  // namespace imubench::plans
