// Parsing plan files into the Plan value type.
#include <gtest/gtest.h>

#include <cmath>

#include "nav/rotation.h"
#include "plan_test_util.h"

namespace imubench::plans {
namespace {

using test::twoAxis;

TEST(ParsePlan, ReadsTableChamberAndEveryStepType) {
  const std::string text = R"(
[plan]
name = "all"
description = "every step type"
recording = "off"

[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
[table.inner]
max_rate = "60 deg/s"
min_angle = "-100 deg"
max_angle = "100 deg"

[chamber]
min_temp = "-40 degC"
max_temp = "70 degC"
max_ramp = "2 degC/min"

[[step]]
type = "move"
outer = "90 deg"
inner = "-30 deg"
rate = "5 deg/s"
label = "m"

[[step]]
type = "rotate"
axis = "outer"
angle = "180 deg"
direction = "cw"

[[step]]
type = "rate"
axis = "outer"
rate = "-30 deg/s"
duration = "1 min"

[[step]]
type = "chamber"
setpoint = "40 degC"
soak = "2 h"

[[step]]
type = "record"
state = "on"

[[step]]
type = "repeat"
count = 3
  [[step.steps]]
  type = "hold"
  duration = "1500 ms"
)";
  io::Diagnostics diag("all.toml");
  auto plan = parsePlan(text, "all.toml", diag);
  ASSERT_TRUE(plan) << diag.str();
  EXPECT_EQ(plan->name, "all");
  EXPECT_FALSE(plan->recording_at_start);
  EXPECT_EQ(plan->table.kind, calib::TableKind::kTwoAxis);
  EXPECT_NEAR(plan->table.outer_axis_heading, 90.0 * kDegToRad, 1e-15);  // default
  const EffectiveLimits outer = limitsFor(plan->table, 0);
  const EffectiveLimits inner = limitsFor(plan->table, 1);
  EXPECT_NEAR(*outer.max_rate, 20.0 * kDegToRad, 1e-15);
  EXPECT_FALSE(outer.limited);
  EXPECT_NEAR(*inner.max_rate, 60.0 * kDegToRad, 1e-15);
  EXPECT_NEAR(*inner.max_accel, 10.0 * kDegToRad, 1e-15);
  EXPECT_TRUE(inner.limited);
  EXPECT_NEAR(inner.min_angle, -100.0 * kDegToRad, 1e-15);
  ASSERT_TRUE(plan->chamber);
  EXPECT_DOUBLE_EQ(plan->chamber->initial.value, 20.0);
  EXPECT_NEAR(plan->chamber->max_ramp.value, 2.0 / 60.0, 1e-15);

  ASSERT_EQ(plan->steps.size(), 6u);
  const Step& move = plan->steps[0];
  EXPECT_EQ(move.type, StepType::kMove);
  EXPECT_EQ(move.label, "m");
  ASSERT_EQ(move.targets.size(), 2u);
  EXPECT_EQ(move.targets[0].axis, "outer");
  EXPECT_NEAR(move.targets[1].angle.value, -30.0 * kDegToRad, 1e-15);
  EXPECT_EQ(move.targets[1].axis_where.line, 24);
  ASSERT_TRUE(move.rate);
  EXPECT_FALSE(move.accel);

  const Step& rot = plan->steps[1];
  EXPECT_EQ(rot.type, StepType::kRotate);
  EXPECT_EQ(rot.axis, "outer");
  EXPECT_NEAR(rot.angle.value, -kPi, 1e-15) << "cw means negative";

  const Step& rate = plan->steps[2];
  EXPECT_EQ(rate.type, StepType::kRate);
  EXPECT_NEAR(rate.rate->value, -30.0 * kDegToRad, 1e-15);
  EXPECT_DOUBLE_EQ(rate.duration.value, 60.0);

  const Step& ch = plan->steps[3];
  EXPECT_EQ(ch.type, StepType::kChamber);
  EXPECT_DOUBLE_EQ(ch.setpoint.value, 40.0);
  EXPECT_FALSE(ch.ramp);
  EXPECT_DOUBLE_EQ(ch.soak.value, 7200.0);

  EXPECT_EQ(plan->steps[4].type, StepType::kRecord);
  EXPECT_TRUE(plan->steps[4].record_on);

  const Step& rep = plan->steps[5];
  EXPECT_EQ(rep.type, StepType::kRepeat);
  EXPECT_EQ(rep.count, 3);
  ASSERT_EQ(rep.steps.size(), 1u);
  EXPECT_DOUBLE_EQ(rep.steps[0].duration.value, 1.5);
  EXPECT_EQ(rep.steps[0].where.line, 52);
}

TEST(ParsePlan, InlineTableStepsAreAccepted) {
  io::Diagnostics diag("inline.toml");
  // Top-level keys must come before the first [section].
  auto plan = parsePlan(
      "step = [ { type = \"hold\", duration = \"2 s\" } ]\n" + std::string(test::kTwoAxisHeader),
      "inline.toml", diag);
  ASSERT_TRUE(plan) << diag.str();
  ASSERT_EQ(plan->steps.size(), 1u);
  EXPECT_DOUBLE_EQ(plan->steps[0].duration.value, 2.0);
}

TEST(ParsePlan, DirectionSignsAngle) {
  for (auto [dir, sign] : {std::pair{"+", 1.0}, {"ccw", 1.0}, {"-", -1.0}, {"cw", -1.0}}) {
    io::Diagnostics diag("d.toml");
    auto plan = parsePlan(twoAxis(std::string("[[step]]\ntype = \"rotate\"\naxis = \"inner\"\n"
                                              "angle = \"90 deg\"\ndirection = \"") +
                                  dir + "\"\n"),
                          "d.toml", diag);
    ASSERT_TRUE(plan) << diag.str();
    EXPECT_NEAR(plan->steps[0].angle.value, sign * 0.5 * kPi, 1e-15) << dir;
  }
}

TEST(ParsePlan, SignedAngleWithDirectionIsRefused) {
  io::Diagnostics diag("d.toml");
  auto plan = parsePlan(twoAxis("[[step]]\ntype = \"rotate\"\naxis = \"inner\"\n"
                                "angle = \"-90 deg\"\ndirection = \"+\"\n"),
                        "d.toml", diag);
  EXPECT_FALSE(plan);
  ASSERT_EQ(diag.items().size(), 1u) << diag.str();
  EXPECT_EQ(diag.items()[0].line, 12);
  EXPECT_NE(diag.items()[0].message.find("must be unsigned when direction is given"),
            std::string::npos);
}

TEST(ParsePlan, BadDirectionNamed) {
  io::Diagnostics diag("d.toml");
  EXPECT_FALSE(parsePlan(twoAxis("[[step]]\ntype = \"rotate\"\naxis = \"inner\"\n"
                                 "angle = \"90 deg\"\ndirection = \"clockwise\"\n"),
                         "d.toml", diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].line, 13);
  EXPECT_NE(diag.items()[0].message.find("direction must be"), std::string::npos);
}

TEST(ParsePlan, PartialParseKeepsThePlanAndMarksBadSteps) {
  const std::string text = twoAxis(R"([[step]]
type = "hold"
duration = 5

[[step]]
type = "hold"
duration = "5 s"
)");
  io::Diagnostics strict("p.toml");
  EXPECT_FALSE(parsePlan(text, "p.toml", strict));
  EXPECT_EQ(strict.items().size(), 1u);
  io::Diagnostics partial("p.toml");
  auto plan = parsePlanPartial(text, "p.toml", partial);
  ASSERT_TRUE(plan);
  ASSERT_EQ(plan->steps.size(), 2u);
  EXPECT_FALSE(plan->steps[0].complete);
  EXPECT_TRUE(plan->steps[1].complete);
  EXPECT_FALSE(expand(*plan).status.ok) << "expand must refuse a plan with parse errors";
}

TEST(ParsePlan, MissingTableAndStepsAreReported) {
  io::Diagnostics diag("empty.toml");
  EXPECT_FALSE(parsePlan("[plan]\nname = \"x\"\n", "empty.toml", diag));
  const std::string all = diag.str();
  EXPECT_NE(all.find("missing required [table] table"), std::string::npos) << all;
  EXPECT_NE(all.find("the plan has no steps"), std::string::npos) << all;
}

TEST(ParsePlan, NonStringQuantityTypeIsNamed) {
  io::Diagnostics diag("t.toml");
  EXPECT_FALSE(parsePlan(twoAxis("[[step]]\ntype = \"hold\"\nduration = true\n"), "t.toml", diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_NE(diag.items()[0].message.find("must be a string like"), std::string::npos);
}

TEST(ParsePlan, RepeatCountMustBeAnInteger) {
  io::Diagnostics diag("r.toml");
  EXPECT_FALSE(parsePlan(twoAxis("[[step]]\ntype = \"repeat\"\ncount = \"3\"\n"
                                 "[[step.steps]]\ntype = \"hold\"\nduration = \"1 s\"\n"),
                         "r.toml", diag));
  ASSERT_EQ(diag.items().size(), 1u) << diag.str();
  EXPECT_EQ(diag.items()[0].line, 11);
  EXPECT_NE(diag.items()[0].message.find("must be an integer"), std::string::npos);
}

TEST(ParsePlan, OuterAxisHeadingOnlyForTwoAxis) {
  io::Diagnostics diag("h.toml");
  EXPECT_FALSE(parsePlan(R"([table]
kind = "three-axis"
outer_axis_heading = "0 deg"
max_rate = "1 deg/s"
max_accel = "1 deg/s^2"
[[step]]
type = "hold"
duration = "1 s"
)",
                         "h.toml", diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].line, 3);
}

TEST(LoadPlanFile, UnreadableFileIsADiagnostic) {
  io::Diagnostics diag("/nonexistent/plan.toml");
  EXPECT_FALSE(loadPlanFile("/nonexistent/plan.toml", diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_NE(diag.str().find("/nonexistent/plan.toml: cannot open plan file"), std::string::npos)
      << diag.str();
}

TEST(AxisNames, FollowMotionAxisOrder) {
  EXPECT_EQ(axisIndex(calib::TableKind::kTwoAxis, "outer"), 0);
  EXPECT_EQ(axisIndex(calib::TableKind::kTwoAxis, "inner"), 1);
  EXPECT_FALSE(axisIndex(calib::TableKind::kTwoAxis, "middle"));
  EXPECT_EQ(axisIndex(calib::TableKind::kThreeAxis, "middle"), 1);
  EXPECT_EQ(axisIndex(calib::TableKind::kThreeAxis, "inner"), 2);
}

}  // namespace
}  // namespace imubench::plans
