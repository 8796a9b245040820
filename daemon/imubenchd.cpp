// imubenchd: the bench daemon. One process per bench (bench file: daemon/bench_file.h);
// commanded over its control socket (daemon/control_protocol.h), logs to syslog, talks to
// systemd (Type=notify, watchdog, socket activation: systemd/).
//
//   imubenchd --bench /etc/imubench/bench.toml [--socket PATH] [--db PATH] [--stderr]
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <iostream>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"  // CLI11's inlined string code (GCC 12)
#include <CLI/CLI.hpp>
#pragma GCC diagnostic pop

#include "daemon/bench_daemon.h"
#include "imubench_build_id.h"

namespace {

using namespace imubench::daemon;

// SIGTERM/SIGINT arrive through a signalfd on the loop: an orderly stop (the run is aborted
// and closed, the socket removed) instead of dying mid-write.
bool watchSignals(BenchDaemon& daemon, const Logger& log) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  if (sigprocmask(SIG_BLOCK, &set, nullptr) != 0) return false;
  const int fd = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
  if (fd < 0) return false;
  signal(SIGPIPE, SIG_IGN);
  return daemon.loop()
      .add(fd, EPOLLIN,
           [fd, &daemon, &log](std::uint32_t) {
             signalfd_siginfo si{};
             if (read(fd, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
               log.info("signal " + std::to_string(si.ssi_signo) + ": stopping");
               daemon.stop();
             }
           })
      .ok;
}

}  // namespace

int main(int argc, char** argv) {
  std::string bench_file = "/etc/imubench/bench.toml";
  DaemonOptions options;
  bool to_stderr = false;
  CLI::App app{"imubenchd: the imubench bench daemon"};
  app.add_option("--bench", bench_file, "bench file (TOML)");
  app.add_option("--socket", options.socket_path, "control socket path (default: bench file's)");
  app.add_option("--db", options.storage_path, "SQLite store (default: bench file's)");
  app.add_flag("--stderr", to_stderr, "also log to stderr (foreground runs)");
  app.set_version_flag("--version", IMUBENCH_BUILD_ID);
  CLI11_PARSE(app, argc, argv);

  Logger log("imubenchd", to_stderr);
  log.info(std::string("imubenchd: ") + IMUBENCH_BUILD_ID);
  imubench::io::Diagnostics diag(bench_file);
  auto bench = loadBenchFile(bench_file, diag);
  if (!bench) {
    log.error("bench file refused:\n" + diag.str());
    return 2;
  }
  BenchDaemon daemon(std::move(*bench), options, log);
  if (auto st = daemon.start(); !st.ok) {
    log.error("start-up failed: " + st.message);
    return 1;
  }
  if (!watchSignals(daemon, log)) log.warning("cannot watch SIGTERM/SIGINT");
  const auto st = daemon.run();
  if (!st.ok) {
    log.error("event loop: " + st.message);
    return 1;
  }
  return 0;
}
