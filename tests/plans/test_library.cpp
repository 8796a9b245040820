// The bundled plans (plans/library/): they parse, validate and expand, and they do what the
// science needs, checked with the nominal table kinematics of interchange.md:
//   two-axis   C_LB = Rx(outer) Rz(inner)
//   three-axis C_LB = Rz(outer) Rx(middle) Rz(inner)
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "nav/rotation.h"
#include "plan_test_util.h"

namespace imubench::plans {
namespace {

using calib::Motion;
using calib::SegmentKind;
using calib::TableKind;

struct Loaded {
  Plan plan;
  Motion motion;
};

Loaded load(const std::string& name) {
  const std::string path = test::kLibraryDir + "/" + name;
  io::Diagnostics diag(path);
  auto plan = loadPlanFile(path, diag);
  EXPECT_TRUE(plan) << diag.str();
  if (!plan) return {};
  EXPECT_TRUE(validatePlan(*plan, diag)) << diag.str();
  ExpandResult r = expand(*plan);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  return {*plan, r.motion};
}

Mat3 C_LB(const Motion& m, double t) {
  if (m.kind == TableKind::kTwoAxis) return Rx(m.axes[0].at(t).angle) * Rz(m.axes[1].at(t).angle);
  return Rz(m.axes[0].at(t).angle) * Rx(m.axes[1].at(t).angle) * Rz(m.axes[2].at(t).angle);
}

// Direction in L of table axis `axis` at time t.
Vec3 tableAxisL(const Motion& m, int axis, double t) {
  const double a0 = m.axes[0].at(t).angle;
  if (m.kind == TableKind::kTwoAxis)
    return axis == 0 ? Vec3::UnitX() : Vec3(Rx(a0) * Vec3::UnitZ());
  if (axis == 0) return Vec3::UnitZ();
  if (axis == 1) return Rz(a0) * Vec3::UnitX();
  return Rz(a0) * Rx(m.axes[1].at(t).angle) * Vec3::UnitZ();
}

Vec3 imuAxis(char letter) {
  return letter == 'x' ? Vec3::UnitX() : (letter == 'y' ? Vec3::UnitY() : Vec3::UnitZ());
}

std::vector<calib::Segment> ofKind(const Motion& m, SegmentKind kind) {
  std::vector<calib::Segment> out;
  for (const auto& s : m.segments) {
    if (s.kind == kind) out.push_back(s);
  }
  return out;
}

TEST(Library, EveryBundledPlanChecksAndExpandsSanely) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test::kLibraryDir)) {
    if (entry.path().extension() != ".toml") continue;
    ++n;
    SCOPED_TRACE(entry.path().string());
    const PlanCheck c = checkPlan(entry.path().string());
    ASSERT_TRUE(c.status.ok) << test::allDiagnostics(c);
    const Loaded l = load(entry.path().filename().string());
    const Motion& m = l.motion;
    EXPECT_GT(m.duration, 10 * 60.0);
    EXPECT_LT(m.duration, 12 * 3600.0);
    EXPECT_NEAR(c.summary.duration_s, m.duration, 1e-9);
    ASSERT_FALSE(m.segments.empty());
    for (size_t k = 0; k < m.segments.size(); ++k) {
      EXPECT_LT(m.segments[k].t0, m.segments[k].t1);
      if (k > 0) {
        EXPECT_GE(m.segments[k].t0, m.segments[k - 1].t1 - 1e-9);
      }
    }
    EXPECT_LE(m.segments.back().t1, m.duration + 1e-9);
    for (int a = 0; a < calib::axisCount(m.kind); ++a) {
      const EffectiveLimits lim = limitsFor(l.plan.table, a);
      for (const auto& p : m.axes[static_cast<size_t>(a)].phases()) {
        EXPECT_LE(std::abs(p.rate0), *lim.max_rate * (1 + 1e-12));
        EXPECT_LE(std::abs(p.accel), *lim.max_accel * (1 + 1e-12));
      }
      EXPECT_EQ(m.axes[static_cast<size_t>(a)].at(m.duration).rate, 0.0) << "ends at rest";
    }
    // Static segments really are static.
    for (const auto& s : ofKind(m, SegmentKind::kStatic)) {
      for (const auto& axis : m.axes) {
        EXPECT_EQ(axis.at(0.5 * (s.t0 + s.t1)).rate, 0.0) << s.label;
        EXPECT_NEAR(axis.at(s.t0).angle, axis.at(s.t1).angle, 1e-12) << s.label;
      }
    }
  }
  EXPECT_EQ(n, 8);
}

// The 12-run checks shared by the two-axis plan and its thermal repetition.
void expectTwelveRuns(const Motion& m, const std::vector<calib::Segment>& runs,
                      const std::string& prefix) {
  ASSERT_EQ(runs.size(), 12u);
  std::map<char, std::multiset<int>> senses;     // IMU axis -> sense of the turn about it
  std::map<char, std::vector<Vec3>> directions;  // IMU axis -> its direction in L
  for (size_t k = 0; k < runs.size(); ++k) {
    const auto& s = runs[k];
    char name[32];
    std::snprintf(name, sizeof name, "run%02zu_", k + 1);
    ASSERT_EQ(s.label.rfind(prefix + name, 0), 0u) << s.label;
    const char letter = s.label[prefix.size() + 6];
    SCOPED_TRACE(s.label);
    EXPECT_NEAR(std::abs(s.angle), kPi, 1e-12);
    EXPECT_EQ(s.axis, letter == 'z' ? 1 : 0) << "x/y turned by outer, z by inner";
    for (double t : {s.t0, 0.5 * (s.t0 + s.t1), s.t1}) {
      const Vec3 u = C_LB(m, t) * imuAxis(letter);
      const Vec3 axis = tableAxisL(m, s.axis, t);
      EXPECT_NEAR(u.z(), 0.0, 1e-12) << "IMU axis horizontal";
      EXPECT_NEAR(std::abs(u.dot(axis)), 1.0, 1e-12) << "IMU axis along the rotation axis";
      EXPECT_NEAR(axis.z(), 0.0, 1e-12) << "rotation axis horizontal";
    }
    const Vec3 u0 = C_LB(m, s.t0) * imuAxis(letter);
    const double along = u0.dot(tableAxisL(m, s.axis, s.t0));  // +1 or -1
    senses[letter].insert(s.angle * along > 0 ? 1 : -1);
    directions[letter].push_back(u0);
    // The rotation turns the IMU by 180 deg about its own axis.
    const Mat3 dC = C_LB(m, s.t0).transpose() * C_LB(m, s.t1);
    const Mat3 expected = Eigen::AngleAxisd(kPi, imuAxis(letter)).toRotationMatrix();
    EXPECT_LT((dC - expected).cwiseAbs().maxCoeff(), 1e-12);
    // Static holds right before and after.
    const auto it = std::find_if(m.segments.begin(), m.segments.end(),
                                 [&](const calib::Segment& x) { return x.t0 == s.t0; });
    ASSERT_NE(it, m.segments.begin());
    ASSERT_NE(it + 1, m.segments.end());
    EXPECT_EQ((it - 1)->kind, SegmentKind::kStatic);
    EXPECT_EQ((it - 1)->label, s.label + "_before");
    EXPECT_EQ((it + 1)->kind, SegmentKind::kStatic);
    EXPECT_EQ((it + 1)->label, s.label + "_after");
    EXPECT_NEAR((it - 1)->t1 - (it - 1)->t0, 60.0, 1e-9);
    EXPECT_TRUE(s.recording);
  }
  // Each IMU axis: two placements pointing opposite ways in L, two runs each, and turned
  // both ways about itself.
  for (char letter : {'x', 'y', 'z'}) {
    EXPECT_EQ(senses[letter], (std::multiset<int>{-1, -1, 1, 1})) << letter;
    const auto& d = directions[letter];
    ASSERT_EQ(d.size(), 4u);
    EXPECT_NEAR(d[0].dot(d[1]), 1.0, 1e-12) << letter;
    EXPECT_NEAR(d[0].dot(d[2]), -1.0, 1e-12) << letter;
    EXPECT_NEAR(d[2].dot(d[3]), 1.0, 1e-12) << letter;
  }
}

TEST(Library, TwoAxis12RunPlacesEachImuAxisAlongTheRotationAxis) {
  const Loaded l = load("two_axis_12run.toml");
  EXPECT_EQ(l.motion.kind, TableKind::kTwoAxis);
  expectTwelveRuns(l.motion, ofKind(l.motion, SegmentKind::kRotate), "");
}

TEST(Library, Thermal12RunRepeatsTheRunsAtEachSetpoint) {
  const Loaded l = load("thermal_soak_12run.toml");
  const Motion& m = l.motion;
  const auto rotates = ofKind(m, SegmentKind::kRotate);
  ASSERT_EQ(rotates.size(), 36u);
  const std::vector<std::pair<std::string, double>> temps = {
      {"T-20C/", -20.0}, {"T+20C/", 20.0}, {"T+60C/", 60.0}};
  for (size_t g = 0; g < temps.size(); ++g) {
    std::vector<calib::Segment> runs(rotates.begin() + static_cast<long>(12 * g),
                                     rotates.begin() + static_cast<long>(12 * g + 12));
    expectTwelveRuns(m, runs, temps[g].first);
    for (const auto& r : runs) {
      EXPECT_NEAR(m.temperatureAt(r.t0), temps[g].second, 1e-9) << r.label;
      EXPECT_NEAR(m.temperatureAt(r.t1), temps[g].second, 1e-9) << r.label;
    }
  }
  const auto soaks = ofKind(m, SegmentKind::kSoak);
  ASSERT_EQ(soaks.size(), 4u);
  for (const auto& s : soaks) EXPECT_FALSE(s.recording) << s.label;
  // -20 degC reached from 20 degC at 1 degC/min (40 min) and soaked 60 min.
  EXPECT_NEAR(soaks[0].t1 - soaks[0].t0, 100 * 60.0, 1e-6);
}

TEST(Library, ThreeAxisIndirectTurnsEachImuAxisAboutAHorizontalAxisAtTwoHeadings) {
  const Loaded l = load("three_axis_indirect.toml");
  const Motion& m = l.motion;
  EXPECT_EQ(m.kind, TableKind::kThreeAxis);
  const auto runs = ofKind(m, SegmentKind::kRotate);
  ASSERT_EQ(runs.size(), 12u);
  std::map<char, std::vector<Vec3>> directions;
  for (size_t k = 0; k < runs.size(); ++k) {
    const auto& s = runs[k];
    SCOPED_TRACE(s.label);
    char name[32];
    std::snprintf(name, sizeof name, "run%02zu_", k + 1);
    ASSERT_EQ(s.label.rfind(name, 0), 0u);
    const char letter = s.label[6];
    EXPECT_NEAR(std::abs(s.angle), kPi, 1e-12);
    EXPECT_EQ(s.axis, letter == 'z' ? 2 : 1) << "x/y turned by middle, z by inner";
    for (double t : {s.t0, 0.5 * (s.t0 + s.t1), s.t1}) {
      const Vec3 u = C_LB(m, t) * imuAxis(letter);
      const Vec3 axis = tableAxisL(m, s.axis, t);
      EXPECT_NEAR(u.z(), 0.0, 1e-12);
      EXPECT_NEAR(axis.z(), 0.0, 1e-12);
      EXPECT_NEAR(std::abs(u.dot(axis)), 1.0, 1e-12);
    }
    const Mat3 dC = C_LB(m, s.t0).transpose() * C_LB(m, s.t1);
    EXPECT_LT(
        (dC - Eigen::AngleAxisd(kPi, imuAxis(letter)).toRotationMatrix()).cwiseAbs().maxCoeff(),
        1e-12);
    directions[letter].push_back(C_LB(m, s.t0) * imuAxis(letter));
  }
  // Two placements per IMU axis, horizontal directions 90 deg apart in azimuth.
  for (char letter : {'x', 'y', 'z'}) {
    ASSERT_EQ(directions[letter].size(), 4u);
    EXPECT_NEAR(directions[letter][0].dot(directions[letter][1]), 1.0, 1e-12);
    EXPECT_NEAR(directions[letter][0].dot(directions[letter][2]), 0.0, 1e-12) << letter;
  }
}

void expectDirectPlan(const std::string& file, bool axes_up_in_rate_runs) {
  const Loaded l = load(file);
  const Motion& m = l.motion;
  // Static positions: each IMU axis up and down.
  std::set<std::pair<int, int>> up_down;  // (IMU axis, sign)
  int positions = 0;
  for (const auto& s : ofKind(m, SegmentKind::kStatic)) {
    if (s.label.rfind("pos", 0) != 0) continue;
    ++positions;
    EXPECT_NEAR(s.t1 - s.t0, 120.0, 1e-9);
    const Mat3 C = C_LB(m, s.t0);
    for (int k = 0; k < 3; ++k) {
      const double up = C.col(k).z();
      if (std::abs(std::abs(up) - 1.0) < 1e-12) up_down.insert({k, up > 0 ? 1 : -1});
    }
  }
  EXPECT_EQ(positions, 12);
  EXPECT_EQ(up_down.size(), 6u) << "each IMU axis up and down";
  // Rate runs: 3 full turns each way about each IMU axis.
  std::set<std::pair<char, int>> runs;
  for (const auto& s : ofKind(m, SegmentKind::kRotate)) {
    SCOPED_TRACE(s.label);
    ASSERT_EQ(s.label.rfind("rate_", 0), 0u);
    const char letter = s.label[5];
    EXPECT_NEAR(std::abs(s.angle), 6 * kPi, 1e-9);
    const Vec3 u = C_LB(m, s.t0) * imuAxis(letter);
    EXPECT_NEAR(std::abs(u.dot(tableAxisL(m, s.axis, s.t0))), 1.0, 1e-12);
    if (axes_up_in_rate_runs) {
      EXPECT_NEAR(u.z(), 1.0, 1e-12) << "IMU axis pointing up";
    }
    // Whole turns: the table is back where it started.
    EXPECT_LT((C_LB(m, s.t0) - C_LB(m, s.t1)).cwiseAbs().maxCoeff(), 1e-9);
    runs.insert({letter, s.angle > 0 ? 1 : -1});
  }
  EXPECT_EQ(runs.size(), 6u) << "+ and - about x, y and z";
}

TEST(Library, DirectTwoAxis) {
  expectDirectPlan("direct_two_axis.toml", false);
}
TEST(Library, DirectThreeAxis) {
  expectDirectPlan("direct_three_axis.toml", true);
}

TEST(Library, Validation8HeadingTurnsAFullCircleInLevel45DegreeSteps) {
  const Loaded l = load("validation_8heading.toml");
  const Motion& m = l.motion;
  const auto holds = ofKind(m, SegmentKind::kStatic);
  const auto turns = ofKind(m, SegmentKind::kRotate);
  ASSERT_EQ(holds.size(), 9u);
  ASSERT_EQ(turns.size(), 8u);
  std::set<long> headings;
  for (const auto& h : holds) {
    EXPECT_NEAR(h.t1 - h.t0, 900.0, 1e-9);
    EXPECT_NEAR(C_LB(m, h.t0).col(2).z(), 1.0, 1e-15) << "level";
    headings.insert(std::lround(std::remainder(m.axes[1].at(h.t0).angle, 2 * kPi) * kRadToDeg));
  }
  EXPECT_EQ(headings.size(), 8u);
  for (const auto& t : turns) {
    EXPECT_EQ(t.axis, 1);
    EXPECT_NEAR(t.angle, kPi / 4, 1e-15);
  }
  EXPECT_NEAR(m.axes[1].at(m.duration).angle, 2 * kPi, 1e-12);
  EXPECT_EQ(holds[2].label, "heading#3/static");
}

}  // namespace
}  // namespace imubench::plans
