// Every bundled plan (plans/library/*.toml) fits the bundled bench files (daemon/benches/
// *.toml) it is meant for, by the daemon's own check before a start (checkPlanForBench): a
// plan is meant for every bundled bench with its table kind, and each bench file's comment
// names the plans meant for it. Also the check's refusals: a plan or a step asking more than
// the bench allows, and a table whose device file cannot set a motion's profile.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/plan_check.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/validator.h"

namespace imubench::daemon {
namespace {

namespace fs = std::filesystem;
const std::string kSource = IMUBENCH_SOURCE_DIR;

struct Bench {
  std::string file;
  std::string text;
  BenchConfig config;
};

struct LibraryPlan {
  std::string file;
  plans::Plan plan;
  calib::Motion motion;
};

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<Bench> bundledBenches() {
  std::vector<Bench> out;
  for (const auto& e : fs::directory_iterator(kSource + "/daemon/benches")) {
    if (e.path().extension() != ".toml") continue;
    io::Diagnostics diag(e.path().string());
    auto b = loadBenchFile(e.path().string(), diag);
    EXPECT_TRUE(b.has_value()) << diag.str();
    if (b) out.push_back({e.path().filename().string(), readText(e.path()), std::move(*b)});
  }
  return out;
}

// Parsed, validated and expanded, as the daemon does before its bench check.
std::optional<LibraryPlan> loadLibraryPlan(const fs::path& path) {
  io::Diagnostics diag(path.string());
  auto plan = plans::loadPlanFile(path.string(), diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan || !diag.ok()) return std::nullopt;
  auto ex = plans::expand(*plan);
  EXPECT_TRUE(ex.status.ok) << path << ": " << ex.status.message;
  if (!ex.status.ok) return std::nullopt;
  return LibraryPlan{path.filename().string(), std::move(*plan), std::move(ex.motion)};
}

std::optional<LibraryPlan> libraryPlan(const std::string& name) {
  return loadLibraryPlan(kSource + "/plans/library/" + name);
}

TEST(BundledLibrary, EveryPlanFitsTheBundledBenchesItIsMeantFor) {
  const auto benches = bundledBenches();
  EXPECT_GE(benches.size(), 2u);
  int plans_checked = 0;
  for (const auto& e : fs::directory_iterator(kSource + "/plans/library")) {
    if (e.path().extension() != ".toml") continue;
    const auto p = loadLibraryPlan(e.path());
    ASSERT_TRUE(p.has_value()) << e.path();
    int benches_for = 0;
    for (const Bench& b : benches) {
      if (b.config.table.kind != p->plan.table.kind) continue;
      ++benches_for;
      const Status fit = checkPlanForBench(p->plan, p->motion, b.config);
      EXPECT_TRUE(fit.ok) << p->file << " on " << b.file << ": " << fit.message;
      EXPECT_NE(b.text.find(p->file), std::string::npos)
          << b.file << "'s comment does not name " << p->file << ", a plan meant for it";
    }
    EXPECT_GE(benches_for, 1) << p->file << ": no bundled bench with a "
                              << plans::tableKindName(p->plan.table.kind) << " table";
    ++plans_checked;
  }
  EXPECT_GE(plans_checked, 6);
}

TEST(BundledLibrary, BenchLimitsNeverExceedTheDeviceFiles) {
  for (const Bench& b : bundledBenches()) {
    io::Diagnostics diag(b.config.table.file);
    const auto device = drivers::loadTableDevice(b.config.table.file, diag);
    ASSERT_TRUE(device.has_value()) << diag.str();
    EXPECT_LE(b.config.table.limits.max_rate, device->limits.max_rate) << b.file;
    EXPECT_LE(b.config.table.limits.max_accel, device->limits.max_accel) << b.file;
    EXPECT_TRUE(b.config.table.profileSettable()) << b.file;
  }
}

BenchConfig virtualBench() {
  io::Diagnostics diag(kSource + "/daemon/benches/virtual-bench.toml");
  auto b = loadBenchFile(diag.file(), diag);
  EXPECT_TRUE(b.has_value()) << diag.str();
  return b ? *b : BenchConfig{};
}

TEST(PlanCheck, RefusesAPlanAskingMoreThanTheBench) {
  const BenchConfig bench = virtualBench();  // 30 deg/s, 10 deg/s^2
  auto p = libraryPlan("two_axis_12run.toml");
  ASSERT_TRUE(p.has_value());
  ASSERT_TRUE(checkPlanForBench(p->plan, p->motion, bench).ok);
  p->plan.table.max_rate->value = 50 * kDegToRad;
  const Status fit = checkPlanForBench(p->plan, p->motion, bench);
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("asks for more than this bench allows (30 deg/s, 10 deg/s^2)"),
            std::string::npos)
      << fit.message;
}

// A step whose planned profile exceeds the bench is refused even when the plan's [table]
// limits claim less (the check reads what the runner will command, not only the header).
TEST(PlanCheck, RefusesAStepFasterThanTheBench) {
  BenchConfig bench = virtualBench();
  auto p = libraryPlan("two_axis_12run.toml");  // moves at 20 deg/s, 10 deg/s^2
  ASSERT_TRUE(p.has_value());
  bench.table.limits.max_rate = 15 * kDegToRad;
  p->plan.table.max_rate->value = 15 * kDegToRad;
  const Status fit = checkPlanForBench(p->plan, p->motion, bench);
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("step 'place_"), std::string::npos) << fit.message;
  EXPECT_NE(fit.message.find("at 20 deg/s, 10 deg/s^2: more than this bench allows"),
            std::string::npos)
      << fit.message;
}

// A table whose device file gives no way to set a motion's rate and acceleration would run
// the plan at its controller's own profile: the daemon refuses every plan that moves it.
TEST(PlanCheck, RefusesMotionOnATableWithoutAProfile) {
  BenchConfig bench = virtualBench();
  for (auto& a : bench.table.registers.axes) a.rate_limit = a.accel_limit = {};
  auto p = libraryPlan("two_axis_12run.toml");
  ASSERT_TRUE(p.has_value());
  const Status fit = checkPlanForBench(p->plan, p->motion, bench);
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("gives no way to set the rate and acceleration"), std::string::npos)
      << fit.message;
}

TEST(PlanCheck, RefusesTheWrongTableKindAndAMissingChamber) {
  BenchConfig bench = virtualBench();
  auto three = libraryPlan("three_axis_indirect.toml");
  ASSERT_TRUE(three.has_value());
  EXPECT_NE(checkPlanForBench(three->plan, three->motion, bench).message.find("three-axis"),
            std::string::npos);
  bench.chamber.reset();
  auto soak = libraryPlan("thermal_soak_12run.toml");
  ASSERT_TRUE(soak.has_value());
  EXPECT_NE(checkPlanForBench(soak->plan, soak->motion, bench).message.find("chamber"),
            std::string::npos);
}

}  // namespace
}  // namespace imubench::daemon
