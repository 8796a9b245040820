// Status of a file operation in io/: what readers and writers return, so callers check it
// instead of catching exceptions. External input never crashes.
#pragma once

#include <string>
#include <utility>

namespace imubench::io {

struct IoStatus {
  bool ok = true;
  // Empty when ok; otherwise "file:line: reason" (line left out where it does not apply,
  // e.g. a missing file or a JSON value without a position).
  std::string message;
  static IoStatus Ok() { return {}; }
  static IoStatus Error(std::string why) { return {false, std::move(why)}; }
};

}  // namespace imubench::io
