// readRecording speed on a 1 h, 2 kHz imubench-csv/1 recording (7.2 M imu.csv rows).
// Target: < 10 s. The recording is written once to a temp dir under /tmp and removed at exit.
// Reported: seconds per read, ratio to the 10 s target (< 1 meets it), items_per_second (rows),
// cpu_s (CPU of the whole process per read, all threads), peak_rss_MiB.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>

#include "bench/peak_rss.h"
#include "io/recording.h"

namespace {

using imubench::Vec3;
namespace io = imubench::io;
namespace fs = std::filesystem;

constexpr double kRateHz = 2000.0;
constexpr double kDurationS = 3600.0;
constexpr double kTargetS = 10.0;

// Static navigation-grade IMU at 55 deg N: Earth rate + gravity increments with noise, so
// every number has a full-length mantissa like a real recording.
io::Recording makeHourRecording() {
  io::Recording rec;
  rec.latitude_deg = 55.75;
  rec.height_m = 150.0;
  rec.imu_serial = "BENCH-1";
  rec.imu_rate_hz = kRateHz;
  const size_t n = static_cast<size_t>(kRateHz * kDurationS);
  const double dt = 1.0 / kRateHz;
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 1.0);
  rec.imu.resize(n);
  const Vec3 w = Vec3(0.0, 4.1e-5, 6.0e-5) * dt;
  const Vec3 f = Vec3(1e-3, -2e-3, 9.8155) * dt;
  for (size_t k = 0; k < n; ++k) {
    auto& s = rec.imu[k];
    s.t = static_cast<double>(k + 1) * dt;
    s.dtheta = w + Vec3(noise(rng), noise(rng), noise(rng)) * 1e-9;
    s.dvel = f + Vec3(noise(rng), noise(rng), noise(rng)) * 5e-6;
    s.temp_c = 25.0 + 0.01 * noise(rng);
  }
  for (int k = 0; k <= static_cast<int>(kDurationS * 100.0); ++k) {
    io::TableSample s;
    s.t = k * 0.01;
    s.angles_deg = {0.0, 90.0, 0.0};
    rec.table.push_back(s);
  }
  return rec;
}

void BM_ReadRecording1h2kHz(benchmark::State& state, const std::string& dir) {
  size_t rows = 0;
  double wall_s = 0.0;  // own wall clock: rate counters would use CPU time
  double cpu_s = 0.0;   // process CPU, all threads
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu0 = imubench::bench::processCpuS();
    auto r = io::readRecording(dir);
    cpu_s += imubench::bench::processCpuS() - cpu0;
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!r.status.ok) {
      state.SkipWithError(r.status.message.c_str());
      return;
    }
    rows = r.value.imu.size();
    benchmark::DoNotOptimize(r.value.imu.data());
  }
  const double per_read_s = wall_s / static_cast<double>(state.iterations());
  state.SetItemsProcessed(static_cast<int64_t>(rows) * state.iterations());
  state.counters["seconds"] = per_read_s;
  state.counters["ratio_to_10s_target"] = per_read_s / kTargetS;
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["cpu_s"] = cpu_s / static_cast<double>(state.iterations());
  imubench::bench::reportPeakRss(state);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const fs::path dir =
      fs::temp_directory_path() / ("imubench-bench-rec-" + std::to_string(::getpid()));
  {
    const auto rec = makeHourRecording();
    const auto st = io::writeRecording(dir.string(), rec);
    if (!st.ok) {
      std::cerr << "cannot write the benchmark recording: " << st.message << "\n";
      return 1;
    }
  }
  benchmark::RegisterBenchmark("BM_ReadRecording1h2kHz", BM_ReadRecording1h2kHz, dir.string())
      ->Unit(benchmark::kSecond)
      ->UseRealTime()
      ->Iterations(2);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::error_code ec;
  fs::remove_all(dir, ec);
  return 0;
}
