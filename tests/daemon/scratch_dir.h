// The daemon tests' scratch directory: a fresh mkdtemp directory
// $TMPDIR/imubench-<tag>-XXXXXX (or under /tmp), removed at the end of the test. Not a
// pid-named path: concurrent user-mode-linux boots share /tmp and hand out the same pids.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace imubench::daemon::testing {

class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag = "ctl") {
    const char* base = std::getenv("TMPDIR");
    std::string templ =
        std::string(base != nullptr ? base : "/tmp") + "/imubench-" + tag + "-XXXXXX";
    if (mkdtemp(templ.data()) == nullptr) ADD_FAILURE() << "mkdtemp " << templ << " failed";
    path_ = templ;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace imubench::daemon::testing
