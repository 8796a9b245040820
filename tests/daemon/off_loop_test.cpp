// OffLoop (daemon/off_loop.h): a job runs on a worker thread and its result on the loop's
// thread; max_pending bounds the jobs in flight; a job that throws is reported, not fatal; an
// OffLoop destroyed with a job in flight drops its result.
#include "daemon/off_loop.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <stdexcept>
#include <thread>

namespace imubench::daemon {
namespace {

// Turns the loop until done() or 10 s.
template <typename F>
bool turnUntil(EventLoop& loop, F done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!done() && std::chrono::steady_clock::now() < deadline) {
    if (!loop.runOnce(100).ok) return false;
  }
  return done();
}

TEST(OffLoop, ResultRunsOnTheLoopThreadAndPendingIsBounded) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  OffLoop jobs(&loop, 1);
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::thread::id worker;
  std::thread::id result_on;
  int result = 0;
  std::string why;
  ASSERT_TRUE(jobs.run(
      [&, released]() -> std::function<void()> {
        worker = std::this_thread::get_id();
        released.wait();  // held in flight until the test lets go
        return [&] {
          result = 42;
          result_on = std::this_thread::get_id();
        };
      },
      [](const std::string&) {}, &why));
  // One job in flight: a second is refused at once.
  EXPECT_FALSE(
      jobs.run([]() -> std::function<void()> { return [] {}; }, [](const std::string&) {}, &why));
  EXPECT_NE(why.find("busy: 1 requests of this kind are in progress"), std::string::npos) << why;
  release.set_value();
  ASSERT_TRUE(turnUntil(loop, [&] { return result == 42; }));
  EXPECT_EQ(result_on, std::this_thread::get_id());
  EXPECT_NE(worker, std::this_thread::get_id());
  // The slot is free again once the result is in.
  bool second = false;
  ASSERT_TRUE(jobs.run([&]() -> std::function<void()> { return [&] { second = true; }; },
                       [](const std::string&) {}, &why))
      << why;
  EXPECT_TRUE(turnUntil(loop, [&] { return second; }));
}

TEST(OffLoop, AThrowingJobIsReportedOnTheLoop) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  OffLoop jobs(&loop, 2);
  std::string reported;
  std::string why;
  ASSERT_TRUE(jobs.run([]() -> std::function<void()> { throw std::runtime_error("disk on fire"); },
                       [&](const std::string& what) { reported = what; }, &why));
  EXPECT_TRUE(turnUntil(loop, [&] { return !reported.empty(); }));
  EXPECT_EQ(reported, "disk on fire");
}

TEST(OffLoop, ResultsOfAGoneOffLoopAreDropped) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> finished;
  std::future<void> job_done = finished.get_future();
  bool ran = false;
  {
    OffLoop jobs(&loop, 1);
    std::string why;
    ASSERT_TRUE(jobs.run(
        [&, released]() -> std::function<void()> {
          released.wait();
          finished.set_value();
          return [&] { ran = true; };
        },
        [](const std::string&) {}, &why));
  }
  release.set_value();
  ASSERT_EQ(job_done.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  // Nothing was posted: a turn of the loop with a short timeout runs nothing.
  ASSERT_TRUE(loop.runOnce(50).ok);
  EXPECT_FALSE(ran);
}

}  // namespace
}  // namespace imubench::daemon
