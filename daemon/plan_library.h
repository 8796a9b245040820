// The bench's plan library (the bench file's plan_dir): the only plan files imubenchd reads on
// a client's behalf. Clients send other plans as text, read with their own rights.
//
// A path from a client is checked lexically first (no file-system call, so a refusal can be
// answered on the event loop's thread): absolute, normalized, inside plan_dir. Only then is the
// file read, on a worker thread, never on the loop: opened O_NONBLOCK (a FIFO or a leased file
// does not block the open), regular files only, at most max_bytes, and its real path (symlinks
// resolved) still inside plan_dir. The result comes back on the loop's thread (OffLoop). A file
// system that hangs pins one worker; at most max_pending are in flight.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "daemon/event_loop.h"
#include "daemon/off_loop.h"

namespace imubench::daemon {

struct PlanLibraryOptions {
  std::string plan_dir;  // empty: no library, every path is refused
  // Plans are a few KiB (the bundled 12-run plan is 3 KiB); 1 MiB bounds what one request can
  // make the daemon read and parse.
  std::size_t max_bytes = 1024 * 1024;
  // Reads in flight. Each is a thread that a hung file system can pin; beyond this the request
  // is refused (busy) instead of piling up threads.
  std::size_t max_pending = 4;
};

struct PlanFile {
  // Not ok: "path: why" (never any of the file's contents).
  Status status = Status::Error("not read");
  std::string text;  // the file's contents, when status.ok
};

// Why a client-given path is not read (nullopt: it is inside plan_dir). Lexical only.
std::optional<std::string> refuseLibraryPath(const std::string& path, const std::string& plan_dir);

// Reads one library file (blocking: call it off the loop). Checks as described above.
PlanFile readLibraryFile(const std::string& path, const PlanLibraryOptions& options);

// The library's plans: the regular *.toml files directly in plan_dir (symlinks followed),
// sorted (blocking: off the loop).
// Empty without a plan_dir or when it cannot be read.
std::vector<std::string> listLibraryFiles(const std::string& plan_dir);

class PlanLibrary {
 public:
  // loop must outlive the library.
  PlanLibrary(EventLoop* loop, PlanLibraryOptions options);
  // Reads still in flight are abandoned: their threads finish without calling back.
  ~PlanLibrary() = default;
  PlanLibrary(const PlanLibrary&) = delete;
  PlanLibrary& operator=(const PlanLibrary&) = delete;

  const PlanLibraryOptions& options() const { return options_; }

  // Starts reading path (already accepted by refuseLibraryPath) on a worker thread; done runs
  // on the loop's thread with the result. false with *why when max_pending reads are in
  // flight or no thread can be started (done is then never called).
  bool read(const std::string& path, std::function<void(PlanFile)> done, std::string* why);
  // Lists the library on a worker thread (listLibraryFiles); done as for read.
  bool list(std::function<void(std::vector<std::string>)> done, std::string* why);

 private:
  PlanLibraryOptions options_;
  OffLoop jobs_;
};

}  // namespace imubench::daemon
