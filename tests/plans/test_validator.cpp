// Validation: every broken plan fails with the right file:line:column and reason; all errors
// are collected; the 180-degree rule, limits, ranges and chamber checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "plan_test_util.h"

namespace imubench::plans {
namespace {

using test::allDiagnostics;
using test::twoAxis;

struct Expectation {
  int line = 0;
  int column = 0;
  std::string substring;
};

// "# expect: LINE:COLUMN: substring" lines at the top of a broken plan.
std::vector<Expectation> expectationsOf(const std::string& path) {
  std::ifstream in(path);
  std::vector<Expectation> out;
  std::string line;
  while (std::getline(in, line)) {
    const std::string tag = "# expect: ";
    if (line.rfind(tag, 0) != 0) continue;
    std::istringstream ss(line.substr(tag.size()));
    Expectation e;
    char colon = 0;
    ss >> e.line >> colon >> e.column >> colon;
    std::getline(ss, e.substring);
    if (!e.substring.empty() && e.substring.front() == ' ') e.substring.erase(0, 1);
    out.push_back(e);
  }
  return out;
}

std::vector<std::string> brokenPlans() {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(test::kBrokenDir)) {
    if (entry.path().extension() == ".toml") files.push_back(entry.path().filename().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

class BrokenPlan : public ::testing::TestWithParam<std::string> {};

TEST_P(BrokenPlan, FailsAtTheRightPlaceWithTheRightReason) {
  const std::string path = test::kBrokenDir + "/" + GetParam();
  const auto expected = expectationsOf(path);
  ASSERT_FALSE(expected.empty()) << path << " has no '# expect:' lines";
  const PlanCheck check = checkPlan(path);
  EXPECT_FALSE(check.status.ok);
  const std::string all = allDiagnostics(check);
  for (const auto& e : expected) {
    const bool found = std::any_of(
        check.diagnostics.begin(), check.diagnostics.end(), [&](const io::Diagnostic& d) {
          return d.file == path && d.line == e.line && d.column == e.column &&
                 d.message.find(e.substring) != std::string::npos;
        });
    EXPECT_TRUE(found) << "expected " << e.line << ":" << e.column << ": " << e.substring
                       << "\ngot:\n"
                       << all;
  }
  // Nothing beyond what the file announces (no follow-on noise).
  EXPECT_EQ(check.diagnostics.size(), expected.size()) << all;
}

std::string testName(const ::testing::TestParamInfo<std::string>& param) {
  return param.param.substr(0, param.param.size() - 5);  // file name without ".toml"
}

INSTANTIATE_TEST_SUITE_P(Files, BrokenPlan, ::testing::ValuesIn(brokenPlans()), testName);

TEST(BrokenPlans, TheRequiredCasesExist) {
  const auto files = brokenPlans();
  for (const char* f : {"unknown_axis.toml", "rate_above_limit.toml", "missing_units.toml",
                        "wrong_unit.toml", "move_180.toml", "unknown_key.toml", "bad_syntax.toml",
                        "zero_duration.toml", "nested_repeat_error.toml", "many_errors.toml"}) {
    EXPECT_NE(std::find(files.begin(), files.end(), f), files.end()) << f;
  }
}

PlanCheck check(const std::string& text) {
  return checkPlanText(text, "t.toml");
}

TEST(Validator, MoveNear180IsAmbiguousButRotateIsNot) {
  auto near = check(twoAxis("[[step]]\ntype = \"move\"\nouter = \"179.5 deg\"\n"));
  EXPECT_FALSE(near.status.ok);
  EXPECT_NE(allDiagnostics(near).find("180-degree move is ambiguous"), std::string::npos);
  auto fine =
      check(twoAxis("[[step]]\ntype = \"move\"\nouter = \"178 deg\"\n"
                    "[[step]]\ntype = \"hold\"\nduration = \"1 s\"\n"));
  EXPECT_TRUE(fine.status.ok) << allDiagnostics(fine);
  auto rotate =
      check(twoAxis("[[step]]\ntype = \"rotate\"\naxis = \"outer\"\nangle = \"180 deg\"\n"));
  EXPECT_TRUE(rotate.status.ok) << allDiagnostics(rotate);
}

TEST(Validator, The180RuleFollowsTheTableThroughRotationsAndRepeats) {
  // After 3 x +120 deg the outer axis is at 360 = 0: a move to 180 is ambiguous there, and
  // only in the iteration where it happens; the diagnostic is reported once.
  auto c = check(twoAxis(R"([[step]]
type = "repeat"
count = 3
  [[step.steps]]
  type = "rotate"
  axis = "outer"
  angle = "120 deg"
[[step]]
type = "move"
outer = "180 deg"
)"));
  EXPECT_FALSE(c.status.ok);
  ASSERT_EQ(c.diagnostics.size(), 1u) << allDiagnostics(c);
  EXPECT_EQ(c.diagnostics[0].line, 18);
  EXPECT_NE(c.diagnostics[0].message.find("180-degree move is ambiguous"), std::string::npos);
  // At 120 deg, 180 is only 60 deg away.
  auto ok = check(twoAxis(R"([[step]]
type = "rotate"
axis = "outer"
angle = "120 deg"
[[step]]
type = "move"
outer = "180 deg"
)"));
  EXPECT_TRUE(ok.status.ok) << allDiagnostics(ok);
}

TEST(Validator, LimitedAxisRangesAndNoRateRuns) {
  const std::string header = R"(
[table]
kind = "two-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
[table.outer]
min_angle = "-10 deg"
max_angle = "190 deg"
)";
  // On a limited axis a move goes the direct way: 0 -> 180 is not ambiguous.
  auto direct = check(header + "[[step]]\ntype = \"move\"\nouter = \"180 deg\"\n");
  EXPECT_TRUE(direct.status.ok) << allDiagnostics(direct);
  auto outside = check(header +
                       "[[step]]\ntype = \"move\"\nouter = \"200 deg\"\n"
                       "[[step]]\ntype = \"rotate\"\naxis = \"outer\"\nangle = \"-220 deg\"\n"
                       "[[step]]\ntype = \"rate\"\naxis = \"outer\"\nrate = \"5 deg/s\"\n"
                       "duration = \"10 s\"\n");
  const std::string all = allDiagnostics(outside);
  EXPECT_NE(all.find("t.toml:11:9: target 200 deg outside the outer axis range"), std::string::npos)
      << all;
  EXPECT_NE(all.find("t.toml:15:9: rotation ends at -20 deg, outside the outer axis range"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("t.toml:18:8: a constant-rate run needs a continuous axis"), std::string::npos)
      << all;
}

TEST(Validator, AccelAndPerAxisLimits) {
  auto c = check(R"(
[table]
kind = "three-axis"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
[table.inner]
max_rate = "100 deg/s"
[[step]]
type = "rotate"
axis = "inner"
angle = "90 deg"
rate = "90 deg/s"
accel = "11 deg/s^2"
[[step]]
type = "rotate"
axis = "middle"
angle = "90 deg"
rate = "21 deg/s"
)");
  EXPECT_FALSE(c.status.ok);
  ASSERT_EQ(c.diagnostics.size(), 2u) << allDiagnostics(c);
  EXPECT_EQ(c.diagnostics[0].line, 13);
  EXPECT_NE(c.diagnostics[0].message.find("accel 11 deg/s^2 above the inner axis limit 10"),
            std::string::npos);
  EXPECT_EQ(c.diagnostics[1].line, 18);
  EXPECT_NE(c.diagnostics[1].message.find("rate 21 deg/s above the middle axis limit 20"),
            std::string::npos);
}

TEST(Validator, MissingTableLimitsAreNamed) {
  auto c = check(
      "[table]\nkind = \"two-axis\"\nmax_rate = \"1 deg/s\"\n"
      "[[step]]\ntype = \"hold\"\nduration = \"1 s\"\n");
  EXPECT_FALSE(c.status.ok);
  const std::string all = allDiagnostics(c);
  EXPECT_NE(all.find("no acceleration limit for the outer axis"), std::string::npos) << all;
  EXPECT_NE(all.find("no acceleration limit for the inner axis"), std::string::npos) << all;
}

TEST(Validator, ChamberChecks) {
  const std::string chamber =
      "[chamber]\nmin_temp = \"-40 degC\"\nmax_temp = \"70 degC\"\n"
      "max_ramp = \"1 degC/min\"\n";
  auto no_chamber =
      check(twoAxis("[[step]]\ntype = \"chamber\"\nsetpoint = \"30 degC\"\n"
                    "soak = \"1 min\"\n"));
  EXPECT_NE(
      allDiagnostics(no_chamber).find("t.toml:9:1: chamber step but the plan has no [chamber]"),
      std::string::npos)
      << allDiagnostics(no_chamber);
  auto fast = check(twoAxis(chamber + "[[step]]\ntype = \"chamber\"\nsetpoint = \"30 degC\"\n"
                                      "ramp = \"5 degC/min\"\nsoak = \"-1 min\"\n"));
  const std::string all = allDiagnostics(fast);
  EXPECT_NE(all.find("t.toml:16:8: ramp 5 degC/min above the chamber limit 1 degC/min"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("t.toml:17:8: soak must not be negative"), std::string::npos) << all;
}

TEST(Validator, RunawayRepeatCountIsRefused) {
  auto c =
      check(twoAxis("[[step]]\ntype = \"repeat\"\ncount = 1000\n"
                    "  [[step.steps]]\n  type = \"repeat\"\n  count = 100000\n"
                    "    [[step.steps.steps]]\n    type = \"hold\"\n    duration = \"1 s\"\n"));
  EXPECT_FALSE(c.status.ok);
  ASSERT_EQ(c.diagnostics.size(), 1u) << allDiagnostics(c);
  EXPECT_EQ(c.diagnostics[0].line, 11);
  EXPECT_NE(c.diagnostics[0].message.find("unrolls to more than"), std::string::npos);
}

TEST(Validator, RecordingOffThenOnIsFine) {
  auto c =
      check(twoAxis("[[step]]\ntype = \"record\"\nstate = \"off\"\n"
                    "[[step]]\ntype = \"hold\"\nduration = \"1 s\"\n"
                    "[[step]]\ntype = \"record\"\nstate = \"on\"\n"
                    "[[step]]\ntype = \"hold\"\nduration = \"1 s\"\n"));
  EXPECT_TRUE(c.status.ok) << allDiagnostics(c);
  EXPECT_DOUBLE_EQ(c.summary.recording_s, 1.0);
  EXPECT_DOUBLE_EQ(c.summary.duration_s, 2.0);
}

TEST(Validator, OptionsAreChecked) {
  ValidatorOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.ambiguous_move_tolerance = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

TEST(CheckPlan, SummaryOfASmallPlan) {
  auto c = check(twoAxis(R"([[step]]
type = "hold"
duration = "10 s"
[[step]]
type = "rotate"
axis = "outer"
angle = "90 deg"
rate = "10 deg/s"
accel = "10 deg/s^2"
)"));
  ASSERT_TRUE(c.status.ok) << allDiagnostics(c);
  EXPECT_EQ(c.summary.holds, 1);
  EXPECT_EQ(c.summary.rotates, 1);
  EXPECT_EQ(c.summary.segments, 2);
  // 90 deg at 10 deg/s with 10 deg/s^2: 1 s ramps (5 deg each) + 8 s cruise = 10 s.
  EXPECT_NEAR(c.summary.duration_s, 20.0, 1e-12);
  const std::string s = formatSummary(c.summary);
  EXPECT_NE(s.find("1 rotate"), std::string::npos) << s;
  EXPECT_NE(s.find("0h 00m 20s"), std::string::npos) << s;
}

}  // namespace
}  // namespace imubench::plans
