#include "daemon/event_loop.h"

#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

namespace imubench::daemon {
namespace {

constexpr int kMaxEventsPerTurn = 64;

Status errnoStatus(const std::string& what) {
  return Status::Error(what + ": " + std::strerror(errno));
}

timespec toTimespec(std::chrono::nanoseconds ns) {
  const auto s = std::chrono::duration_cast<std::chrono::seconds>(ns);
  return {static_cast<time_t>(s.count()), static_cast<long>((ns - s).count())};
}

std::uint64_t eventData(int fd, std::uint32_t generation) {
  return (std::uint64_t{generation} << 32) | static_cast<std::uint32_t>(fd);
}

}  // namespace

EventLoop::~EventLoop() {
  for (const int tfd : timers_) ::close(tfd);  // timers are the loop's own fds
  if (wake_fd_ >= 0) ::close(wake_fd_);
  if (first_fd_ >= 0) ::close(first_fd_);
  if (epoll_fd_ >= 0) ::close(epoll_fd_);
}

Status EventLoop::open() {
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) return errnoStatus("epoll_create1");
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) return errnoStatus("eventfd");
  return add(wake_fd_, EPOLLIN, [this](std::uint32_t) { drainWake(); });
}

Status EventLoop::add(int fd, std::uint32_t events, FdCallback callback) {
  return addTo(epoll_fd_, fd, events, std::move(callback), false);
}

Status EventLoop::addFirst(int fd, std::uint32_t events, FdCallback callback) {
  if (first_fd_ < 0) {
    first_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
    if (first_fd_ < 0) return errnoStatus("epoll_create1");
    // Its readiness only wakes the loop: runOnce serves it first (serveFirst) every turn.
    if (Status s = add(first_fd_, EPOLLIN, [](std::uint32_t) {}); !s.ok) return s;
  }
  return addTo(first_fd_, fd, events, std::move(callback), true);
}

Status EventLoop::addTo(int epoll_fd, int fd, std::uint32_t events, FdCallback callback,
                        bool first) {
  const std::uint32_t generation = next_generation_++;
  epoll_event ev{};
  ev.events = events;
  ev.data.u64 = eventData(fd, generation);
  if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0)
    return errnoStatus("epoll_ctl(ADD, fd " + std::to_string(fd) + ")");
  watches_[fd] = {generation, std::make_shared<FdCallback>(std::move(callback)), first};
  return Status::Ok();
}

Status EventLoop::modify(int fd, std::uint32_t events) {
  const auto it = watches_.find(fd);
  if (it == watches_.end()) return Status::Error("fd " + std::to_string(fd) + " not watched");
  epoll_event ev{};
  ev.events = events;
  ev.data.u64 = eventData(fd, it->second.generation);
  if (::epoll_ctl(it->second.first ? first_fd_ : epoll_fd_, EPOLL_CTL_MOD, fd, &ev) != 0)
    return errnoStatus("epoll_ctl(MOD, fd " + std::to_string(fd) + ")");
  return Status::Ok();
}

void EventLoop::remove(int fd) {
  const auto it = watches_.find(fd);
  if (it == watches_.end()) return;
  const int epoll_fd = it->second.first ? first_fd_ : epoll_fd_;
  watches_.erase(it);
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
}

Status EventLoop::addTimer(std::chrono::nanoseconds first, std::chrono::nanoseconds interval,
                           std::function<void()> callback, TimerId* id) {
  const int tfd = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (tfd < 0) return errnoStatus("timerfd_create");
  itimerspec spec{};
  // A zero it_value would disarm the timer: the earliest expiry is 1 ns.
  spec.it_value = toTimespec(std::max(first, std::chrono::nanoseconds(1)));
  spec.it_interval = toTimespec(interval);
  if (::timerfd_settime(tfd, 0, &spec, nullptr) != 0) {
    const Status s = errnoStatus("timerfd_settime");
    ::close(tfd);
    return s;
  }
  auto cb = [tfd, callback = std::move(callback)](std::uint32_t) {
    std::uint64_t expirations = 0;
    if (::read(tfd, &expirations, sizeof expirations) == sizeof expirations) callback();
  };
  const Status s = add(tfd, EPOLLIN, std::move(cb));
  if (!s.ok) {
    ::close(tfd);
    return s;
  }
  timers_.insert(tfd);
  *id = tfd;
  return Status::Ok();
}

void EventLoop::cancelTimer(TimerId id) {
  if (timers_.erase(id) == 0) return;
  remove(id);
  ::close(id);
}

void EventLoop::post(std::function<void()> fn) {
  {
    std::lock_guard<std::mutex> lock(posted_mutex_);
    posted_.push_back(std::move(fn));
  }
  wake();
}

void EventLoop::stop() {
  stop_ = true;
  wake();
}

void EventLoop::wake() {
  const std::uint64_t one = 1;
  // EAGAIN means the counter is already non-zero: the loop will wake anyway.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof one);
}

void EventLoop::drainWake() {
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(wake_fd_, &count, sizeof count);
  std::vector<std::function<void()>> work;
  {
    std::lock_guard<std::mutex> lock(posted_mutex_);
    work.swap(posted_);
  }
  for (auto& fn : work) fn();
}

void EventLoop::dispatch(const epoll_event& event) {
  const int fd = static_cast<int>(event.data.u64 & 0xffffffffu);
  const auto generation = static_cast<std::uint32_t>(event.data.u64 >> 32);
  const auto it = watches_.find(fd);
  if (it == watches_.end() || it->second.generation != generation) return;
  // Hold the callback: it may remove (destroy) its own watch while running.
  const std::shared_ptr<FdCallback> callback = it->second.callback;
  (*callback)(event.events);
}

// The addFirst fds that are ready now, without waiting.
void EventLoop::serveFirst() {
  if (first_fd_ < 0) return;
  std::array<epoll_event, kMaxEventsPerTurn> events{};
  const int n = ::epoll_wait(first_fd_, events.data(), kMaxEventsPerTurn, 0);
  for (int i = 0; i < n; ++i) dispatch(events[i]);
}

Status EventLoop::runOnce(int timeout_ms) {
  std::array<epoll_event, kMaxEventsPerTurn> events{};
  const int n = ::epoll_wait(epoll_fd_, events.data(), kMaxEventsPerTurn, timeout_ms);
  if (n < 0) return errno == EINTR ? Status::Ok() : errnoStatus("epoll_wait");
  serveFirst();
  for (int i = 0; i < n; ++i) dispatch(events[i]);
  return Status::Ok();
}

Status EventLoop::run() {
  while (!stop_) {
    const Status s = runOnce(-1);
    if (!s.ok) return s;
  }
  stop_ = false;  // a later run() starts afresh
  return Status::Ok();
}

}  // namespace imubench::daemon
