// The concealed-effect suite: prints the table and checks the thresholds.
#include <gtest/gtest.h>

#include "explain_suite.h"

namespace imubench::calib::testing {
namespace {

std::vector<ConcealedCase> exploratoryCases() {
  std::vector<ConcealedCase> cs;
  for (const char* plan :
       {"direct_two_axis", "two_axis_12run", "three_axis_indirect", "direct_three_axis"}) {
    cs.push_back({plan, "clean", {}, 11});
    cs.push_back({plan, "lever_arm 5 cm", leverArm(Vec3(0.05, -0.03, 0.02)), 12});
    cs.push_back({plan, "time_delay 5 ms", timeDelay(5e-3), 13});
    cs.push_back({plan, "g_sens 5 deg/h/g", gSensitivity(5.0), 14});
    cs.push_back({plan, "scale_asym 100 ppm", scaleAsymmetry(100.0), 15});
    cs.push_back({plan, "accel_k2 30 ug/g2", accelK2(30.0), 16});
  }
  for (std::uint64_t seed = 30; seed < 34; ++seed) {
    cs.push_back({"two_axis_12run", "k2seed 50", accelK2(50.0), seed});
  }
  return cs;
}

TEST(ExplainSuite, Exploratory) {
  const char* only = std::getenv("EXPLAIN_ONLY");
  for (const ConcealedCase& c : exploratoryCases()) {
    if (only && (c.plan + " " + c.label).find(only) == std::string::npos) continue;
    printOutcome(runCase(c));
  }
}

}  // namespace
}  // namespace imubench::calib::testing
