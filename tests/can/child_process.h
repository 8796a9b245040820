// Child processes for the CAN tests (candump, canplayer, the virtual bench): started with
// their output in a file, waited for with a bound (pidfd + poll: wakes on the exit itself,
// never a fixed sleep).
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace imubench::drivers::testing {

// Starts args (args[0] searched in PATH unless it has a '/') with stdout -- and stderr too
// when with_stderr -- written to out_path (inherited when out_path is empty). Returns the
// pid, or -1 on failure.
inline pid_t spawnChild(const std::vector<std::string>& args, const std::string& out_path,
                        bool with_stderr = false) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  if (!out_path.empty()) {
    posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (with_stderr) posix_spawn_file_actions_adddup2(&fa, 1, 2);
  }
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

// Waits up to timeout_ms for the child to exit, then kills it (SIGKILL). Returns its exit
// code, or -1 when it had to be killed or died by a signal.
inline int waitChild(pid_t pid, int timeout_ms) {
  const int pfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
  if (pfd >= 0) {
    pollfd p{pfd, POLLIN, 0};
    const int r = poll(&p, 1, timeout_ms);
    close(pfd);
    if (r == 0) kill(pid, SIGKILL);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace imubench::drivers::testing
