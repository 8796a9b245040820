#include "daemon/off_loop.h"

#include <sys/resource.h>
#include <unistd.h>

#include <mutex>
#include <system_error>
#include <thread>
#include <utility>

namespace imubench::daemon {
namespace {

// Workers run at the lowest priority: whatever they do (parse, format a whole run), the loop's
// thread (IMU frames, table polls, the socket) gets the CPU first when it wakes.
constexpr int kWorkerNice = 19;

}  // namespace

struct OffLoop::Shared {
  std::mutex mutex;
  EventLoop* loop = nullptr;  // null once the owner is gone: results are dropped
  std::size_t pending = 0;
};

OffLoop::OffLoop(EventLoop* loop, std::size_t max_pending)
    : max_pending_(max_pending), shared_(std::make_shared<Shared>()) {
  shared_->loop = loop;
}

OffLoop::~OffLoop() {
  const std::lock_guard<std::mutex> lock(shared_->mutex);
  shared_->loop = nullptr;
}

bool OffLoop::run(Job job, Failed failed, std::string* why) {
  {
    const std::lock_guard<std::mutex> lock(shared_->mutex);
    if (shared_->pending >= max_pending_) {
      *why = "busy: " + std::to_string(shared_->pending) +
             " requests of this kind are in progress (is a file system hanging?); try again "
             "later";
      return false;
    }
    ++shared_->pending;
  }
  try {
    std::thread([shared = shared_, job = std::move(job), failed = std::move(failed)] {
      // Best effort: at worst the worker competes at the loop's priority.
      (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kWorkerNice);
      std::function<void()> done;
      try {
        done = job();
      } catch (const std::exception& e) {
        // A bug in the job must not take the daemon down (a detached thread's exception
        // would terminate it): the loop reports it instead.
        done = [failed, what = std::string(e.what())] { failed(what); };
      }
      const std::lock_guard<std::mutex> lock(shared->mutex);
      --shared->pending;
      if (shared->loop != nullptr) shared->loop->post(std::move(done));
    }).detach();
  } catch (const std::system_error& e) {
    const std::lock_guard<std::mutex> lock(shared_->mutex);
    --shared_->pending;
    *why = std::string("cannot start a worker thread: ") + e.what();
    return false;
  }
  return true;
}

}  // namespace imubench::daemon
