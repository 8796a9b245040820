// daemon/store append speed: one second of a bench run (2,000 IMU samples in 20-sample
// batches, as the IMU reader hands them over, plus 100 table samples) through RunWriter into
// the SQLite store, committed every 0.5 s of sample time as in a real run. Target: far above
// real time (>= 10x: the daemon shares the core with the control loop). Reported:
// x_realtime (recorded seconds stored per wall second), items_per_second (rows).
// Also loading a 10 min run back as a Recording (what a calibration on a run id costs).
// The database lives in a mkdtemp directory, removed at exit.
#include <benchmark/benchmark.h>
#include <stdlib.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <random>

#include "bench/peak_rss.h"
#include "daemon/store.h"

namespace {

using imubench::Vec3;
namespace daemon = imubench::daemon;
namespace io = imubench::io;
namespace nav = imubench::nav;
namespace fs = std::filesystem;

constexpr double kImuRateHz = 2000.0;
constexpr double kTableRateHz = 100.0;
constexpr int kImuBatch = 20;  // 10 ms of IMU samples per append

daemon::RunStart benchStart() {
  daemon::RunStart s;
  s.plan_name = "bench";
  s.imu_serial = "BENCH-1";
  s.imu_rate_hz = kImuRateHz;
  s.latitude_deg = 55.75;
  s.height_m = 150.0;
  return s;
}

// Appends sample-time second `second` (0-based) of a static noisy IMU and a turning table.
bool appendSecond(daemon::RunWriter& writer, long second, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 1.0);
  const double dt = 1.0 / kImuRateHz;
  nav::ImuSamples batch(kImuBatch);
  const long k0 = second * static_cast<long>(kImuRateHz);
  for (long k = 0; k < static_cast<long>(kImuRateHz); k += kImuBatch) {
    for (int i = 0; i < kImuBatch; ++i) {
      auto& s = batch[static_cast<size_t>(i)];
      s.t = static_cast<double>(k0 + k + i + 1) * dt;
      s.dtheta = Vec3(noise(rng), noise(rng), 6e-5 + noise(rng)) * 1e-9;
      s.dvel = Vec3(noise(rng) * 5e-6, noise(rng) * 5e-6, 9.8155 * dt);
      s.temp_c = 25.0 + 0.01 * noise(rng);
    }
    if (!writer.appendImu(batch).ok) return false;
    // One table sample per 10 ms batch: 100 Hz.
    const io::TableSample table{batch.back().t, {10.0 * batch.back().t, 90.0, 0.0}};
    if (!writer.appendTable(std::span(&table, 1)).ok) return false;
  }
  return true;
}

// The store at db_path with a run begun (its id in *run); nullptr, the benchmark skipped with
// the reason, when either fails.
std::unique_ptr<daemon::Store> openWithRun(benchmark::State& state, const std::string& db_path,
                                           std::int64_t* run) {
  auto opened = daemon::Store::open(db_path);
  if (!opened.status.ok) {
    state.SkipWithError(opened.status.message.c_str());
    return nullptr;
  }
  const auto begun = opened.value->beginRun(benchStart());
  if (!begun.status.ok) {
    state.SkipWithError(begun.status.message.c_str());
    return nullptr;
  }
  *run = begun.value;
  return std::move(opened.value);
}

void BM_StoreAppendSecondOf2kHz(benchmark::State& state, const std::string& db_path) {
  std::int64_t run = 0;
  const auto store = openWithRun(state, db_path, &run);
  if (!store) return;
  daemon::RunWriter writer(*store, run);
  std::mt19937_64 rng(42);
  long second = 0;
  double wall_s = 0.0;  // own wall clock: rate counters would use CPU time
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    if (!appendSecond(writer, second++, rng)) return state.SkipWithError("append failed");
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  if (!writer.flush().ok) return state.SkipWithError("flush failed");
  const double rows_per_second = kImuRateHz + kTableRateHz;
  state.SetItemsProcessed(static_cast<int64_t>(rows_per_second) * state.iterations());
  state.counters["x_realtime"] = static_cast<double>(state.iterations()) / wall_s;
  state.counters["rows_per_s"] = rows_per_second * static_cast<double>(state.iterations()) / wall_s;
  imubench::bench::reportPeakRss(state);
}

void BM_StoreLoad10MinRun(benchmark::State& state, const std::string& db_path) {
  std::int64_t run = 0;
  const auto store = openWithRun(state, db_path, &run);
  if (!store) return;
  {
    daemon::RunWriter writer(*store, run);
    std::mt19937_64 rng(7);
    for (long s = 0; s < 600; ++s)
      if (!appendSecond(writer, s, rng)) return state.SkipWithError("append failed");
    if (!writer.flush().ok) return state.SkipWithError("flush failed");
  }
  size_t rows = 0;
  for (auto _ : state) {
    auto r = store->loadRecording(run);
    if (!r.status.ok) return state.SkipWithError(r.status.message.c_str());
    rows = r.value.imu.size() + r.value.table.size();
    benchmark::DoNotOptimize(r.value.imu.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(rows) * state.iterations());
  state.counters["rows"] = static_cast<double>(rows);
  imubench::bench::reportPeakRss(state);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const char* base = std::getenv("TMPDIR");
  std::string dir = std::string(base != nullptr ? base : "/tmp") + "/imubench-bench-store-XXXXXX";
  if (mkdtemp(dir.data()) == nullptr) {
    std::cerr << "cannot create a temp directory " << dir << "\n";
    return 1;
  }
  const std::string db = dir + "/bench.db";
  benchmark::RegisterBenchmark("BM_StoreAppendSecondOf2kHz", BM_StoreAppendSecondOf2kHz, db)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("BM_StoreLoad10MinRun", BM_StoreLoad10MinRun, db)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::error_code ec;
  fs::remove_all(dir, ec);
  return 0;
}
