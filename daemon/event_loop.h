// A small epoll event loop: one per bench in imubenchd. File descriptors with a callback,
// timers (timerfd), and post() to hand work to the loop's thread from other threads.
// Level-triggered: a callback that leaves data unread is called again on the next turn, so a
// busy fd can be served in bounded slices without starving the others.
#pragma once

#include <sys/epoll.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "base/status.h"

namespace imubench::daemon {

class EventLoop {
 public:
  // events: the EPOLL* bits that fired (EPOLLIN, EPOLLOUT, EPOLLHUP, EPOLLERR, ...).
  using FdCallback = std::function<void(std::uint32_t events)>;
  using TimerId = int;  // the timerfd

  EventLoop() = default;
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  // Creates the epoll instance and the wake-up eventfd. Call once before anything else.
  Status open();

  // Watches fd for events (EPOLLIN | EPOLLOUT ...). The loop does not own fd; remove() it
  // before closing it. A callback may add, modify or remove any fd, including its own.
  Status add(int fd, std::uint32_t events, FdCallback callback);
  // The same for an fd served first: on every turn its events are taken and handled before
  // any other fd's callback, however many others are ready (the emergency stop's socket).
  Status addFirst(int fd, std::uint32_t events, FdCallback callback);
  Status modify(int fd, std::uint32_t events);
  void remove(int fd);

  // A timer firing first after `first`, then every `interval` (zero: once). The callback gets
  // no arguments; a one-shot timer stays allocated until cancelTimer().
  Status addTimer(std::chrono::nanoseconds first, std::chrono::nanoseconds interval,
                  std::function<void()> callback, TimerId* id);
  void cancelTimer(TimerId id);

  // Thread-safe: runs fn on the loop's thread during its next turn.
  void post(std::function<void()> fn);

  // One epoll_wait (up to timeout_ms, -1 = forever) and the callbacks of what fired.
  Status runOnce(int timeout_ms);
  // Turns until stop(); returns the first epoll error, if any.
  Status run();
  // Thread-safe: run() returns after the current turn.
  void stop();

 private:
  struct Watch {
    std::uint32_t generation = 0;
    std::shared_ptr<FdCallback> callback;
    bool first = false;  // in first_fd_'s set (addFirst)
  };
  Status addTo(int epoll_fd, int fd, std::uint32_t events, FdCallback callback, bool first);
  void dispatch(const epoll_event& event);
  void serveFirst();
  void wake();
  void drainWake();

  int epoll_fd_ = -1;
  int wake_fd_ = -1;  // eventfd: post() and stop() from other threads
  // An epoll instance of the addFirst fds, itself watched by epoll_fd_ (it wakes the loop);
  // polled without waiting at the start of every turn's dispatch. -1 until the first addFirst.
  int first_fd_ = -1;
  // Events carry (generation << 32 | fd), so an event of a removed fd whose number was reused
  // within the same epoll_wait batch is recognized as stale and dropped.
  std::unordered_map<int, Watch> watches_;
  std::unordered_set<int> timers_;  // timerfds this loop created (closed with it)
  std::uint32_t next_generation_ = 1;
  std::atomic<bool> stop_{false};
  std::mutex posted_mutex_;
  std::vector<std::function<void()>> posted_;
};

}  // namespace imubench::daemon
