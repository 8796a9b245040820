// The one status and result shape of imubench: what a library call returns -- file readers and
// writers (io/), device drivers (drivers/), the store and the daemon's commands (daemon/) --
// so the caller checks it (like Ceres' Summary) instead of catching exceptions. External
// input never crashes. Pure header in base/ (imubench_base), the lowest library every one of
// them links.
#pragma once

#include <string>
#include <utility>

namespace imubench {

struct Status {
  bool ok = true;
  // Empty when ok; otherwise why, naming what failed: "file:line: reason" for input files
  // (line left out where it does not apply), the device and request for a driver, the
  // database path for the store.
  std::string message;
  static Status Ok() { return {}; }
  static Status Error(std::string why) { return {false, std::move(why)}; }
};

// A status and the payload it vouches for: `value` is meaningful only when ok().
template <typename T>
struct Result {
  Status status;
  T value{};
  bool ok() const { return status.ok; }
  static Result Error(std::string why) { return {Status::Error(std::move(why)), T{}}; }
};

}  // namespace imubench
