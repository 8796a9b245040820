// The one way an options struct's IsValid(std::string* why) refuses a value: it says why (when
// the caller asked) and returns false, so each check is one line:
//   if (!(window_s > 0.0)) return invalidOption(why, "window_s must be > 0");
#pragma once

#include <string>

namespace imubench::calib {

inline bool invalidOption(std::string* why, const char* message) {
  if (why) *why = message;
  return false;
}

}  // namespace imubench::calib
