// Peak memory and process CPU for the benchmarks (issue 31): every benchmark reports the
// process's peak resident set (getrusage ru_maxrss, the high-water mark since the process
// started, so it includes the benchmark's own setup) and, where threads may run, the CPU of
// the whole process (Google Benchmark's cpu_time is the calling thread's only).
#pragma once

#include <benchmark/benchmark.h>
#include <sys/resource.h>

namespace imubench::bench {

// Peak resident set of this process so far, MiB.
inline double peakRssMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// User + system CPU of the whole process (all threads) so far, s.
inline double processCpuS() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * t.tv_usec; };
  return s(u.ru_utime) + s(u.ru_stime);
}

// Adds the counter "peak_rss_MiB" to the benchmark's report.
inline void reportPeakRss(benchmark::State& state) {
  state.counters["peak_rss_MiB"] = peakRssMiB();
}

}  // namespace imubench::bench
