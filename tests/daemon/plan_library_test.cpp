// The plan library (daemon/plan_library.h): which client paths are read at all (lexically,
// no file-system call), what a read refuses (FIFOs, oversized files, symlinks out of the
// library) and the result coming back on the loop's thread.
#include "daemon/plan_library.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

#include "tests/daemon/control_test_util.h"

namespace imubench::daemon {
namespace {

using testing::ScratchDir;

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(PlanLibrary, OnlyPathsInsideThePlanDirAreRead) {
  EXPECT_FALSE(refuseLibraryPath("/lib/plans/a.toml", "/lib/plans").has_value());
  EXPECT_FALSE(refuseLibraryPath("/lib/plans/sub/../a.toml", "/lib/plans/").has_value());
  for (const char* outside :
       {"/lib/plans/../secret.toml", "/lib/plansx/a.toml", "/lib/plans", "/etc/shadow"}) {
    const auto why = refuseLibraryPath(outside, "/lib/plans");
    ASSERT_TRUE(why.has_value()) << outside;
    EXPECT_TRUE(has(*why, "not in this bench's plan library (/lib/plans)")) << *why;
    EXPECT_TRUE(has(*why, "send the plan's text")) << *why;
  }
  const auto none = refuseLibraryPath("/a.toml", "");
  ASSERT_TRUE(none.has_value());
  EXPECT_TRUE(has(*none, "this bench has no plan library")) << *none;
}

class PlanLibraryFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    ::mkdir(lib_.c_str(), 0755);
    std::ofstream(lib_ + "/good.toml") << "[plan]\nname = \"g\"\n";
    std::ofstream(dir_.file("secret.toml")) << "secret = 1\n";
    options_.plan_dir = lib_;
    options_.max_bytes = 100;
  }
  ScratchDir dir_;
  std::string lib_ = dir_.file("lib");
  PlanLibraryOptions options_;
};

TEST_F(PlanLibraryFiles, ReadsRegularFilesAndRefusesTheRest) {
  const PlanFile good = readLibraryFile(lib_ + "/good.toml", options_);
  ASSERT_TRUE(good.status.ok) << good.status.message;
  EXPECT_EQ(good.text, "[plan]\nname = \"g\"\n");

  ASSERT_EQ(::mkfifo((lib_ + "/fifo.toml").c_str(), 0644), 0);
  const auto t0 = std::chrono::steady_clock::now();
  const PlanFile fifo = readLibraryFile(lib_ + "/fifo.toml", options_);  // no writer: no wait
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(1));
  EXPECT_FALSE(fifo.status.ok);
  EXPECT_TRUE(has(fifo.status.message, "fifo.toml: not a regular file")) << fifo.status.message;

  std::ofstream(lib_ + "/big.toml") << std::string(101, '#');
  const PlanFile big = readLibraryFile(lib_ + "/big.toml", options_);
  EXPECT_FALSE(big.status.ok);
  EXPECT_TRUE(has(big.status.message, "101 bytes, more than the 100 bytes a plan may have"))
      << big.status.message;

  ASSERT_EQ(::symlink(dir_.file("secret.toml").c_str(), (lib_ + "/link.toml").c_str()), 0);
  const PlanFile link = readLibraryFile(lib_ + "/link.toml", options_);
  EXPECT_FALSE(link.status.ok);
  EXPECT_TRUE(has(link.status.message, "resolves outside this bench's plan library"))
      << link.status.message;
  EXPECT_FALSE(has(link.status.message, "secret = 1"));

  const PlanFile outside = readLibraryFile(dir_.file("secret.toml"), options_);
  EXPECT_FALSE(outside.status.ok);
  EXPECT_TRUE(has(outside.status.message, "not in this bench's plan library"))
      << outside.status.message;
  EXPECT_FALSE(readLibraryFile(lib_ + "/none.toml", options_).status.ok);

  // The listing: regular *.toml files (and symlinks to them), sorted; no FIFO.
  std::ofstream(lib_ + "/notes.txt") << "x";
  EXPECT_EQ(
      listLibraryFiles(lib_),
      (std::vector<std::string>{lib_ + "/big.toml", lib_ + "/good.toml", lib_ + "/link.toml"}));
  EXPECT_TRUE(listLibraryFiles("").empty());
  EXPECT_TRUE(listLibraryFiles(dir_.file("none")).empty());
}

TEST_F(PlanLibraryFiles, ResultComesBackOnTheLoopThread) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  PlanLibrary library(&loop, options_);
  std::optional<PlanFile> got;
  std::thread::id ran_on;
  std::string why;
  ASSERT_TRUE(library.read(
      lib_ + "/good.toml",
      [&](PlanFile f) {
        got = std::move(f);
        ran_on = std::this_thread::get_id();
      },
      &why))
      << why;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!got && std::chrono::steady_clock::now() < deadline) ASSERT_TRUE(loop.runOnce(100).ok);
  ASSERT_TRUE(got.has_value());
  EXPECT_TRUE(got->status.ok) << got->status.message;
  EXPECT_EQ(ran_on, std::this_thread::get_id());
}

}  // namespace
}  // namespace imubench::daemon
