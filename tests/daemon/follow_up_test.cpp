// The daemon's follow-up experiment (daemon/follow_up.h, issue 27 item 3) on simulated
// recordings: the stored proposal separates a concealed pair within the bench's limits, names
// the groups no plan can separate with the reason, and the joint analysis of the origin and a
// recording of its proposal resolves the pair.
#include "daemon/follow_up.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "explain_sim.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/proposal.h"
#include "plans/validator.h"

namespace imubench::daemon {
namespace {

using calib::testing::SimulatedRecording;
using calib::testing::simulateWith;
using nlohmann::json;

constexpr double kArcsec = kPi / 180.0 / 3600.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using calib::testing::givenBaseline;
using calib::testing::levelOptions;
using calib::testing::planFileMotion;

calib::EffectSet concealedTiltAndNonorthogonality() {
  calib::EffectSet e;
  e.enable(calib::EffectId::kNonorthogonality);
  e.nonorthogonality->inner_y = 30.0 * kArcsec;
  e.enable(calib::EffectId::kBaseTilt);
  e.base_tilt->x = 0.0;
  e.base_tilt->y = -20.0 * kArcsec;
  return e;
}

const json* groupOf(const json& groups, const std::vector<std::string>& effects) {
  for (const json& g : groups) {
    auto e = g.value("effects", std::vector<std::string>());
    std::sort(e.begin(), e.end());
    if (e == effects) return &g;
  }
  return nullptr;
}

// A bench slower than the virtual bench's default: 12 deg/s, 4 deg/s^2.
FollowUpSetup slowBench(std::int64_t run) {
  FollowUpSetup s;
  s.run_id = run;
  s.method = plans::CalibrationMethod::kDirect;
  s.propose.limits.max_rate_rad_s = 12.0 * kPi / 180.0;
  s.propose.limits.max_accel_rad_s2 = 4.0 * kPi / 180.0;
  return s;
}

TEST(FollowUp, NothingUnseparableIsNothingToFollowUp) {
  const calib::ExplainInput none;
  const calib::ExplainResult clean;
  EXPECT_FALSE(proposeFollowUp(none, clean, calib::ExplainOptions{}, slowBench(1)).has_value());
}

// The level recording's base_tilt + nonorthogonality: a proposal whose plan parses, validates,
// stays within the bench's limits and is named after the run; then a recording of that plan
// (same truth) analysed jointly with the origin resolves the pair within 10 % or 2 sigma, the
// achieved sigmas within a factor 1.5 of the stored prediction.
TEST(FollowUp, ProposalWithinTheBenchLimitsAndTheJointVerdictResolvesThePair) {
  const calib::EffectSet e = concealedTiltAndNonorthogonality();
  const std::string level = std::string(IMUBENCH_SOURCE_DIR) + "/tests/explain/level_headings.toml";
  const SimulatedRecording rec = simulateWith(planFileMotion(level), e, 35);
  const calib::ExplainInput input = givenBaseline(rec);
  const calib::ExplainResult r = calib::explainRecording(input, levelOptions());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const FollowUpSetup setup = slowBench(7);
  const auto f = proposeFollowUp(input, r, levelOptions(), setup);
  ASSERT_TRUE(f.has_value());
  std::cout << followUpSummary(*f) << "\n";
  ASSERT_EQ(f->value("status", ""), "proposed") << f->dump(2);
  EXPECT_EQ((*f)["run"], 7);
  EXPECT_EQ((*f)["method"], "direct");
  EXPECT_EQ((*f)["plan"]["name"], "follow_up_of_run_7");
  EXPECT_NEAR((*f)["limits"]["max_rate_deg_s"].get<double>(), 12.0, 1e-9);
  const json* g = groupOf((*f)["groups"], {"base_tilt", "nonorthogonality"});
  ASSERT_NE(g, nullptr) << f->dump(2);
  EXPECT_TRUE((*g)["resolved"].get<bool>());
  EXPECT_GT((*g)["angle_after_deg"].get<double>(), (*g)["limit_deg"].get<double>());
  EXPECT_NE(followUpSummary(*f).find("follow_up_of_run_7"), std::string::npos);

  io::Diagnostics diag("follow_up_of_run_7");
  const std::string toml = (*f)["plan"]["toml"].get<std::string>();
  auto plan = plans::parsePlan(toml, "follow_up_of_run_7", diag);
  ASSERT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str() << toml;
  for (int axis = 0; axis < 2; ++axis) {
    const plans::EffectiveLimits lim = plans::limitsFor(plan->table, axis);
    ASSERT_TRUE(lim.max_rate && lim.max_accel);
    EXPECT_LE(*lim.max_rate, setup.propose.limits.max_rate_rad_s * (1 + 1e-9));
    EXPECT_LE(*lim.max_accel, setup.propose.limits.max_accel_rad_s2 * (1 + 1e-9));
  }
  const plans::ExpandResult motion = plans::expand(*plan);
  ASSERT_TRUE(motion.status.ok) << motion.status.message;
  const SimulatedRecording follow = simulateWith(motion.motion, e, 36);

  const json j = jointFollowUp(*f, input, givenBaseline(follow), 8, levelOptions());
  ASSERT_TRUE(j.value("ok", false)) << j.dump(2);
  EXPECT_EQ(j["origin_run"], 7);
  EXPECT_EQ(j["run"], 8);
  EXPECT_EQ(j["report"]["format"], "imubench-explain/1");
  const json* v = groupOf(j["groups"], {"base_tilt", "nonorthogonality"});
  ASSERT_NE(v, nullptr) << j.dump(2);
  EXPECT_EQ((*v)["verdict"], "resolved") << j["summary"];
  const std::map<std::string, double> truth = {{"table.base_tilt.x", e.base_tilt->x},
                                               {"table.base_tilt.y", e.base_tilt->y},
                                               {"table.nonorthogonality.inner_y", 30.0 * kArcsec}};
  ASSERT_EQ((*v)["parameters"].size(), truth.size()) << v->dump(2);
  for (const json& p : (*v)["parameters"]) {
    const std::string n = p.value("name", std::string());
    ASSERT_TRUE(truth.count(n)) << n;
    const double value = p.value("value", kNaN), sigma = p.value("sigma", kNaN);
    const double predicted = p.value("sigma_predicted", kNaN);
    EXPECT_LE(std::abs(value - truth.at(n)), std::max(0.1 * std::abs(truth.at(n)), 2.0 * sigma))
        << n;
    EXPECT_LT(sigma, 1.5 * predicted) << n;
    EXPECT_GT(sigma, predicted / 1.5) << n;
  }
}

// On the bundled direct plan a concealed outer encoder zero is unseparable from the base tilt
// on any motion of a two-axis table: the stored follow-up says so with the reason and holds no
// plan (nothing to queue).
TEST(FollowUp, GroupsNoPlanCanSeparateAreRefusedWithTheReason) {
  calib::EffectSet e;
  e.enable(calib::EffectId::kNonorthogonality);
  e.nonorthogonality->inner_y = 30.0 * kArcsec;
  e.enable(calib::EffectId::kEncoderZero);
  e.encoder_zero->outer = 25.0 * kArcsec;
  const std::string direct =
      std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/direct_two_axis.toml";
  const SimulatedRecording rec = simulateWith(planFileMotion(direct), e, 21);
  const calib::ExplainInput input = calib::testing::simulatedExplainInput(rec);
  const calib::ExplainResult r = calib::explainRecording(input);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  const auto f = proposeFollowUp(input, r, {}, slowBench(3));
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->value("status", ""), "refused") << f->dump(2);
  EXPECT_FALSE(f->contains("plan"));
  const std::string reason = f->value("reason", "");
  EXPECT_NE(reason.find("base_tilt + encoder_zero"), std::string::npos) << reason;
  EXPECT_NE(reason.find("no plan within the bench limits"), std::string::npos) << reason;
  EXPECT_EQ(followUpSummary(*f).rfind("follow-up refused: ", 0), 0u) << followUpSummary(*f);
}

}  // namespace
}  // namespace imubench::daemon
