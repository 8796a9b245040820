// imubench: the front end of the command line. The whole CLI (imubench-cli: calibration,
// plans, explain, Ceres and its solvers, about 28 shared libraries) takes 150 ms to load in an
// idle user-mode Linux and 0.6 s on a loaded machine, before main runs; an emergency stop must
// not wait for that (issue 28: the table halts within 100 ms of the command). So `imubench` is
// this small program (libc only): it serves `imubench stop` itself and hands every other
// command line, unchanged, to imubench-cli next to it (execv: same arguments, same process).
//
// Served here: `imubench stop [--socket PATH] [--stop-socket PATH]` (either also as
// --opt=PATH), exactly what imubench-cli's `stop` does without --json (the same
// sendEmergencyStop, output, messages and exit codes: tools/cli_control.cpp runStop). Any other
// word, option or form (--json, --help, a typo) goes to imubench-cli, which parses it.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <optional>
#include <set>
#include <string>
#include <string_view>

#include "tools/control_client.h"

namespace {

using imubench::tools::ControlError;

// The full command line's file name, next to this program (build tree and install alike).
constexpr const char* kFullProgram = "imubench-cli";

struct StopArgs {
  std::string socket = imubench::tools::defaultControlSocket();
  std::string stop_socket;  // empty: socket + ".stop"
};

// `stop` and its options as runStop takes them; nullopt for anything else.
std::optional<StopArgs> parseStop(int argc, char** argv) {
  if (argc < 2 || std::string_view(argv[1]) != "stop") return std::nullopt;
  StopArgs a;
  std::set<std::string_view> seen;
  for (int i = 2; i < argc; ++i) {
    const std::string_view arg = argv[i];
    std::string* into = nullptr;
    std::string_view name;
    for (auto [opt, field] : {std::pair{std::string_view("--socket"), &a.socket},
                              std::pair{std::string_view("--stop-socket"), &a.stop_socket}}) {
      if (arg == opt ||
          (arg.size() > opt.size() && arg.substr(0, opt.size()) == opt && arg[opt.size()] == '=')) {
        into = field;
        name = opt;
      }
    }
    if (into == nullptr || !seen.insert(name).second) return std::nullopt;  // once each
    if (arg.size() > name.size()) {
      *into = std::string(arg.substr(name.size() + 1));
    } else if (i + 1 < argc && argv[i + 1][0] != '-') {
      *into = argv[++i];
    } else {
      return std::nullopt;  // no value: the full CLI says so
    }
    if (into->empty()) return std::nullopt;
  }
  return a;
}

int runStop(const StopArgs& a) {
  try {
    imubench::tools::throwIfRefused(imubench::tools::sendEmergencyStop(a.socket, a.stop_socket));
  } catch (const ControlError& e) {
    std::fprintf(stderr, "imubench: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {  // a reply of the wrong shape (json type errors)
    std::fprintf(stderr, "imubench: error: %s\n", e.what());
    return 1;
  }
  std::printf("%s\n", imubench::tools::kEmergencyStopSent);
  return 0;
}

// The full CLI next to this program, with the same arguments; returns only when it failed.
int runFull(char** argv) {
  char self[4096];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) {
    std::fprintf(stderr, "imubench: cannot find the imubench executable: %s\n",
                 std::strerror(errno));
    return 1;
  }
  std::string program(self, static_cast<std::size_t>(n));
  program = program.substr(0, program.rfind('/') + 1) + kFullProgram;
  ::execv(program.c_str(), argv);
  std::fprintf(stderr, "imubench: cannot run %s: %s\n", program.c_str(), std::strerror(errno));
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (const std::optional<StopArgs> stop = parseStop(argc, argv)) return runStop(*stop);
  return runFull(argv);
}
