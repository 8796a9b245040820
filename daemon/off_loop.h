// Work that may block — a file system call, reading a whole run from SQLite and writing it
// out — run on a worker thread, never on the event loop's thread, with its result handed back
// to the loop through EventLoop::post. One detached thread per job: a job stuck in a hung file
// system pins its own thread and nothing else; at most max_pending are in flight. Workers run
// at nice 19, so the loop's thread gets the CPU first whenever it wakes.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "daemon/event_loop.h"

namespace imubench::daemon {

class OffLoop {
 public:
  // Runs on a worker thread; returns what to do with its result on the loop's thread.
  using Job = std::function<std::function<void()>()>;

  // loop must outlive this object. max_pending >= 1.
  OffLoop(EventLoop* loop, std::size_t max_pending);
  // Jobs still in flight are abandoned: they finish on their threads, their results are
  // dropped (never run on the loop).
  ~OffLoop();
  OffLoop(const OffLoop&) = delete;
  OffLoop& operator=(const OffLoop&) = delete;

  // Runs on the loop's thread instead of the job's result when the job threw (what()).
  using Failed = std::function<void(const std::string& what)>;

  // Starts job on a worker thread. false with *why when max_pending jobs are in flight or no
  // thread can be started (the job never runs).
  bool run(Job job, Failed failed, std::string* why);

 private:
  struct Shared;
  std::size_t max_pending_;
  std::shared_ptr<Shared> shared_;
};

}  // namespace imubench::daemon
