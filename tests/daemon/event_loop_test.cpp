// The EventLoop: fd callbacks, timers, post() from another thread, stop(), and removing a
// watch from inside a callback.
#include "daemon/event_loop.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <thread>
#include <vector>

namespace imubench::daemon {
namespace {

TEST(EventLoop, FdCallbackAndRemoveInsideCallback) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, sv), 0);
  int calls = 0;
  ASSERT_TRUE(loop.add(sv[0], EPOLLIN,
                       [&](std::uint32_t events) {
                         EXPECT_NE(events & EPOLLIN, 0u);
                         ++calls;
                         loop.remove(sv[0]);  // destroys this callback's watch while it runs
                       })
                  .ok);
  ASSERT_EQ(::write(sv[1], "x", 1), 1);
  ASSERT_TRUE(loop.runOnce(1000).ok);
  ASSERT_TRUE(loop.runOnce(0).ok);  // removed: not called again though still readable
  EXPECT_EQ(calls, 1);
  EXPECT_FALSE(loop.modify(sv[0], EPOLLIN).ok);
  ::close(sv[0]);
  ::close(sv[1]);
}

// An addFirst fd is served before every other ready fd of the turn, even when more fds are
// ready than one epoll_wait returns (issue 28: the emergency stop's socket comes first).
TEST(EventLoop, FirstFdIsServedBeforeAnyOther) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  std::vector<std::array<int, 2>> pairs(200);
  std::vector<int> order;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, pairs[i].data()), 0);
    ASSERT_EQ(::write(pairs[i][1], "x", 1), 1);
    const int fd = pairs[i][0];
    const int tag = static_cast<int>(i);
    const auto cb = [&order, &loop, fd, tag](std::uint32_t) {
      order.push_back(tag);
      loop.remove(fd);
    };
    ASSERT_TRUE((i == 150 ? loop.addFirst(fd, EPOLLIN, cb) : loop.add(fd, EPOLLIN, cb)).ok);
  }
  ASSERT_TRUE(loop.runOnce(1000).ok);
  ASSERT_FALSE(order.empty());
  EXPECT_EQ(order.front(), 150) << "the first fd was served after " << order.front();
  // modify and remove reach the first fd's own set.
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, sv), 0);
  int calls = 0;
  ASSERT_TRUE(loop.addFirst(sv[0], 0, [&calls](std::uint32_t) { ++calls; }).ok);
  ASSERT_EQ(::write(sv[1], "x", 1), 1);
  while (order.size() < pairs.size()) ASSERT_TRUE(loop.runOnce(0).ok);
  EXPECT_EQ(calls, 0);
  ASSERT_TRUE(loop.modify(sv[0], EPOLLIN).ok);
  ASSERT_TRUE(loop.runOnce(1000).ok);
  EXPECT_EQ(calls, 1);
  loop.remove(sv[0]);
  ASSERT_TRUE(loop.runOnce(0).ok);
  EXPECT_EQ(calls, 1);
  for (auto& p : pairs) ::close(p[1]);
  for (auto& p : pairs) ::close(p[0]);
  ::close(sv[0]);
  ::close(sv[1]);
}

TEST(EventLoop, TimersFireAndCancel) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  int ticks = 0;
  EventLoop::TimerId periodic = -1, once = -1;
  ASSERT_TRUE(loop.addTimer(
                      std::chrono::milliseconds(1), std::chrono::milliseconds(1),
                      [&] {
                        if (++ticks == 3) loop.stop();
                      },
                      &periodic)
                  .ok);
  bool fired_once = false;
  ASSERT_TRUE(loop.addTimer(
                      std::chrono::nanoseconds(0), std::chrono::nanoseconds(0),
                      [&] { fired_once = true; }, &once)
                  .ok);
  ASSERT_TRUE(loop.run().ok);
  EXPECT_EQ(ticks, 3);
  EXPECT_TRUE(fired_once);
  loop.cancelTimer(periodic);
  loop.cancelTimer(once);
  loop.cancelTimer(once);  // twice is harmless
}

TEST(EventLoop, PostAndStopFromAnotherThread) {
  EventLoop loop;
  ASSERT_TRUE(loop.open().ok);
  int ran = 0;
  std::thread other([&] {
    for (int i = 0; i < 100; ++i) loop.post([&] { ++ran; });
    loop.post([&] { loop.stop(); });
  });
  ASSERT_TRUE(loop.run().ok);
  other.join();
  EXPECT_EQ(ran, 100);
}

}  // namespace
}  // namespace imubench::daemon
