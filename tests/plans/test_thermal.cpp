// Thermal plans: soak = "auto" on chamber steps and the thermal step (soak and ramp modes):
// parse, validate (errors with line and reason; the file cases are in broken/) and expand.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "calib/model/thermal_lag.h"
#include "plan_test_util.h"

namespace imubench::plans {
namespace {

using calib::SegmentKind;
using test::allDiagnostics;

const std::string kChamber = R"(
[chamber]
min_temp = "-40 degC"
max_temp = "70 degC"
max_ramp = "1 degC/min"
)";

std::string plan(const std::string& steps) {
  return test::twoAxis(kChamber + steps);
}

calib::Motion expandText(const std::string& text, const ExpandOptions& options = {}) {
  io::Diagnostics diag("t.toml");
  auto p = parsePlan(text, "t.toml", diag);
  EXPECT_TRUE(p) << diag.str();
  if (!p) return {};
  EXPECT_TRUE(validatePlan(*p, diag)) << diag.str();
  ExpandResult r = expand(*p, options);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return r.motion;
}

const std::string kAutoSoak = R"(
[[step]]
type = "chamber"
setpoint = "-20 degC"
ramp = "1 degC/min"
soak = "auto"
settle_rate = "0.05 degC/min"
settle_hold = "10 min"
max_soak = "5 h"
[[step]]
type = "hold"
duration = "1 min"
)";

TEST(AutoSoak, ParsesAndPlansTheModelsSettlingTime) {
  ExpandOptions o;
  o.thermal = {600.0, 300.0};
  const auto m = expandText(plan(kAutoSoak), o);
  ASSERT_EQ(m.segments.size(), 2u);
  const calib::Segment& soak = m.segments[0];
  EXPECT_EQ(soak.kind, SegmentKind::kSoak);
  EXPECT_TRUE(soak.soak_auto);
  EXPECT_NEAR(soak.settle_rate_c_per_s, 0.05 / 60.0, 1e-15);
  EXPECT_EQ(soak.settle_hold_s, 600.0);
  EXPECT_EQ(soak.max_soak_s, 5 * 3600.0);
  EXPECT_NEAR(soak.ramp_s, 40.0 * 60.0, 1e-9);  // 20 -> -20 degC at 1 degC/min
  const auto st = calib::model::settlingTime(calib::model::thermalAtRest(20.0), -20.0, 1.0 / 60.0,
                                             o.thermal, {0.05 / 60.0, 600.0}, 5 * 3600.0);
  ASSERT_TRUE(st.settled);
  EXPECT_EQ(soak.t1 - soak.t0, st.t_s);
  // The lags make it far longer than ramp + hold; at its end the IMU is close to the setpoint.
  EXPECT_GT(st.t_s, soak.ramp_s + 600.0 + 1200.0);
  EXPECT_NEAR(m.temperatureAt(soak.t1), -20.0, 0.5);
}

TEST(AutoSoak, SettlingTimeMeetsItsCriterionAndNotBefore) {
  const calib::model::ThermalLag lag{900.0, 400.0};
  const calib::model::SettleCriterion c{0.05 / 60.0, 600.0};
  const auto s0 = calib::model::thermalAtRest(20.0);
  const auto st = calib::model::settlingTime(s0, 60.0, 1.0 / 60.0, lag, c, 1e5);
  ASSERT_TRUE(st.settled);
  // Rate by central differences of the closed-form model: below the threshold over the last
  // hold, above it just before.
  auto rate = [&](double t) {
    const double h = 0.5;
    return (calib::model::advanceThermal(s0, 60.0, 1.0 / 60.0, lag, t + h).sensor_c -
            calib::model::advanceThermal(s0, 60.0, 1.0 / 60.0, lag, t - h).sensor_c) /
           (2 * h);
  };
  for (double t = st.t_s - c.hold_s + 5.0; t <= st.t_s; t += 10.0) {
    EXPECT_LT(std::abs(rate(t)), c.rate_c_per_s) << t;
  }
  EXPECT_GT(std::abs(rate(st.t_s - c.hold_s - 10.0)), c.rate_c_per_s);
  // Not within a short maximum: settled = false, at the maximum.
  const auto cut = calib::model::settlingTime(s0, 60.0, 1.0 / 60.0, lag, c, 3000.0);
  EXPECT_FALSE(cut.settled);
  EXPECT_EQ(cut.t_s, 3000.0);
}

const std::string kBody = R"(
  [[step.steps]]
  type = "rotate"
  axis = "inner"
  angle = "90 deg"
  label = "turn"
  [[step.steps]]
  type = "hold"
  duration = "2 min"
  label = "rest"
)";

TEST(ThermalStep, SoakModeRunsTheBodyAtEverySetpointInLegOrder) {
  const auto m = expandText(plan(R"(
[[step]]
type = "thermal"
setpoints = ["60 degC", "-40 degC", "20 degC"]
legs = "heat-cool"
soak = "30 min"
)" + kBody));
  // heat: -40, 20, 60; cool back: 20, -40. Each: soak, turn, rest.
  ASSERT_EQ(m.segments.size(), 15u);
  const char* expected[] = {"T-40C/soak",   "T-40C/turn",   "T-40C/rest",  "T20C/soak",
                            "T20C/turn",    "T20C/rest",    "T60C/soak",   "T60C/turn",
                            "T60C/rest",    "T20C#2/soak",  "T20C#2/turn", "T20C#2/rest",
                            "T-40C#2/soak", "T-40C#2/turn", "T-40C#2/rest"};
  const double setpoints[] = {-40, 20, 60, 20, -40};
  for (std::size_t i = 0; i < 15; ++i) EXPECT_EQ(m.segments[i].label, expected[i]) << i;
  for (std::size_t k = 0; k < 5; ++k) {
    const calib::Segment& soak = m.segments[3 * k];
    EXPECT_EQ(soak.kind, SegmentKind::kSoak);
    EXPECT_EQ(soak.setpoint_c, setpoints[k]);
    // Ramp from the previous setpoint at max_ramp (1 degC/min), then the 30 min soak.
    const double from = k == 0 ? 20.0 : setpoints[k - 1];
    EXPECT_NEAR(soak.t1 - soak.t0, std::abs(setpoints[k] - from) * 60.0 + 1800.0, 1e-6) << k;
    EXPECT_FALSE(soak.soak_auto);
  }
  EXPECT_NEAR(m.temperatureAt(m.segments[7].t0), 60.0, 1e-9);
}

TEST(ThermalStep, LegsSortTheSetpoints) {
  std::vector<Quantity> q{{20, {}}, {-40, {}}, {60, {}}};
  EXPECT_EQ(thermalSetpoints(q, ThermalLegs::kAsWritten), (std::vector<double>{20, -40, 60}));
  EXPECT_EQ(thermalSetpoints(q, ThermalLegs::kHeat), (std::vector<double>{-40, 20, 60}));
  EXPECT_EQ(thermalSetpoints(q, ThermalLegs::kCool), (std::vector<double>{60, 20, -40}));
  EXPECT_EQ(thermalSetpoints(q, ThermalLegs::kHeatCool),
            (std::vector<double>{-40, 20, 60, 20, -40}));
}

TEST(ThermalStep, AutoSoakAndLabelPrefix) {
  const auto m = expandText(plan(R"(
[[step]]
type = "thermal"
label = "cal"
setpoints = ["-10 degC"]
soak = "auto"
max_soak = "3 h"
)" + kBody));
  ASSERT_EQ(m.segments.size(), 3u);
  EXPECT_EQ(m.segments[0].label, "cal/T-10C/soak");
  EXPECT_TRUE(m.segments[0].soak_auto);
  EXPECT_NEAR(m.segments[0].settle_rate_c_per_s, 0.05 / 60.0, 1e-15);  // the defaults
  EXPECT_EQ(m.segments[0].settle_hold_s, 600.0);
  // No lag given: the IMU follows the ramp, settled at its end plus the hold.
  EXPECT_NEAR(m.segments[0].t1 - m.segments[0].t0, 30.0 * 60.0 + 600.0, 4.0);
  EXPECT_EQ(m.segments[2].label, "cal/T-10C/rest");
}

TEST(ThermalStep, RampModeRepeatsTheBodyWhileTheChamberRamps) {
  const auto m = expandText(plan(R"(
[[step]]
type = "thermal"
mode = "ramp"
setpoints = ["-40 degC", "60 degC"]
ramp = "0.5 degC/min"
)" + kBody));
  // No soak segments: the chamber is commanded at the first segment of each leg.
  int commands = 0;
  for (const auto& s : m.segments) {
    EXPECT_NE(s.kind, SegmentKind::kSoak) << s.label;
    commands += s.chamber_command_c ? 1 : 0;
  }
  EXPECT_EQ(commands, 2);
  ASSERT_FALSE(m.segments.empty());
  EXPECT_EQ(m.segments[0].label, "ramp1/rep01/turn");
  EXPECT_EQ(*m.segments[0].chamber_command_c, -40.0);
  // Leg 1: 60 degC at 0.5 degC/min = 120 min; leg 2: 100 degC = 200 min. The body repeats
  // until the leg's ramp is over (the last repetition may run past it by less than one body).
  const double body = m.segments[1].t1 - m.segments[0].t0;
  int leg1 = 0, leg2 = 0;
  double leg2_t0 = 0.0;
  for (const auto& s : m.segments) {
    if (s.label.rfind("ramp1/", 0) == 0 && s.label.find("/rest") != std::string::npos) ++leg1;
    if (s.label.rfind("ramp2/", 0) == 0 && s.label.find("/rest") != std::string::npos) ++leg2;
    if (s.chamber_command_c && *s.chamber_command_c == 60.0) leg2_t0 = s.t0;
  }
  EXPECT_EQ(leg1, static_cast<int>(std::ceil(120.0 * 60.0 / body)));
  EXPECT_EQ(leg2, static_cast<int>(std::ceil(200.0 * 60.0 / body)));
  EXPECT_EQ(m.segments.back().label, "ramp2/rep" + std::to_string(leg2) + "/rest");
  EXPECT_NEAR(leg2_t0, leg1 * body, 1e-6);
  // The temperature follows the ramps: -40 degC at the end of leg 1's ramp.
  EXPECT_NEAR(m.temperatureAt(120.0 * 60.0), -40.0, 1e-6);
  EXPECT_NEAR(m.temperatureAt(leg2_t0 + 100.0 * 60.0), 10.0, 1e-6);
}

PlanCheck check(const std::string& text) {
  return checkPlanText(text, "t.toml");
}

bool hasError(const PlanCheck& c, int line, const std::string& substring) {
  for (const auto& d : c.diagnostics) {
    if (d.line == line && d.message.find(substring) != std::string::npos) return true;
  }
  return false;
}

TEST(ThermalStep, BadInputIsRefusedWithLineAndReason) {
  // Lines: the test header and [chamber] end at line 13; the first [[step]] is line 15.
  const auto bad_leg = check(plan(R"(
[[step]]
type = "thermal"
setpoints = ["-40 degC", 12]
legs = "up"
mode = "fast"
soak = "10 min"
)" + kBody));
  EXPECT_FALSE(bad_leg.status.ok);
  const std::string all = allDiagnostics(bad_leg);
  EXPECT_TRUE(hasError(bad_leg, 17, "each setpoint must be a string with its unit")) << all;
  EXPECT_TRUE(hasError(bad_leg, 18, "legs must be \"heat\", \"cool\" or \"heat-cool\"")) << all;
  EXPECT_TRUE(hasError(bad_leg, 19, "mode must be \"soak\" or \"ramp\"")) << all;

  const auto no_body = check(plan(R"(
[[step]]
type = "thermal"
setpoints = ["-40 degC"]
soak = "10 min"
)"));
  EXPECT_TRUE(hasError(no_body, 15, "a thermal step needs nested steps"))
      << allDiagnostics(no_body);

  const auto fixed_with_rate = check(plan(R"(
[[step]]
type = "chamber"
setpoint = "0 degC"
soak = "10 min"
settle_rate = "0.1 degC/min"
)"));
  EXPECT_TRUE(hasError(fixed_with_rate, 19, "applies to soak = \"auto\" only"))
      << allDiagnostics(fixed_with_rate);

  const auto short_max = check(plan(R"(
[[step]]
type = "chamber"
setpoint = "0 degC"
soak = "auto"
settle_hold = "30 min"
max_soak = "20 min"
)"));
  EXPECT_TRUE(hasError(short_max, 20, "must be longer than settle_hold"))
      << allDiagnostics(short_max);

  const auto no_chamber = check(test::twoAxis(R"(
[[step]]
type = "thermal"
setpoints = ["-40 degC"]
soak = "10 min"
)" + kBody));
  EXPECT_TRUE(hasError(no_chamber, 10, "thermal step but the plan has no [chamber] section"))
      << allDiagnostics(no_chamber);
}

}  // namespace
}  // namespace imubench::plans
