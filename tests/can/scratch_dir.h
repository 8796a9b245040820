// A per-process scratch directory for the CAN tests' files (candump logs, daemon output).
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace imubench::drivers::testing {

// A scratch directory of this process (mkdtemp under $TMPDIR or /tmp), made once. Not a pid-named
// path: identical user-mode-linux boots hand out the same pids and share the host's /tmp.
inline const std::string& scratchDir() {
  static const std::string dir = [] {
    // Read once, by the static's initialiser at the first call (before any test thread).
    const char* base = std::getenv("TMPDIR");  // NOLINT(concurrency-mt-unsafe)
    std::string templ = std::string(base != nullptr ? base : "/tmp") + "/imubench-test-XXXXXX";
    if (mkdtemp(templ.data()) == nullptr) {
      ADD_FAILURE() << "mkdtemp " << templ << " failed";
      return std::string(base != nullptr ? base : "/tmp");
    }
    return templ;
  }();
  static const bool cleanup_registered = [] {
    std::atexit([] { rmdir(scratchDir().c_str()); });  // only when the tests left it empty
    return true;
  }();
  (void)cleanup_registered;
  return dir;
}

inline std::string scratchPath(const std::string& name) {
  return scratchDir() + "/" + name;
}

}  // namespace imubench::drivers::testing
