// Navigation-based (indirect) calibration of a 2 kHz recording of the bundled two-axis 12-run
// plan (plans/library/two_axis_12run.toml), navigation-grade noise and table errors. Target:
// the full calibration in < 10 s on one core. Reports seconds per calibration, the ratio to
// the recording's duration and to the 10 s target.
// Also the whole production pipeline (calib/indirect/bench_calibration.h) at 2 kHz: direct
// calibration of the direct plan's recording, refinement over both recordings, and the second pass
// a nonorthogonal table needs.
#include <benchmark/benchmark.h>

#include "bench/calibration/plan_fixture.h"
#include "bench/peak_rss.h"
#include "calib/indirect/bench_calibration.h"
#include "calib/indirect/indirect_calibration.h"

namespace {

using namespace imubench;
using namespace imubench::calib;

using Fixture = bench::PlanFixture;
using bench::simulatePlan;

const Fixture& fixture() {
  static const Fixture f = simulatePlan("two_axis_12run");
  return f;
}

const Fixture& directFixture() {
  static const Fixture f = simulatePlan("direct_two_axis");
  return f;
}

void BM_IndirectCalibration12Run2kHz(benchmark::State& state) {
  const Fixture& f = fixture();
  if (!f.ok) {
    state.SkipWithError("could not load/expand/simulate the 12-run plan");
    return;
  }
  IndirectInput in;
  in.site.latitude_rad = 58.0 * kDegToRad;
  in.site.height_m = 100.0;
  in.imu = f.sim.imu;
  in.table = f.sim.table;
  in.segments = f.sim.segments;
  int iterations = 0;
  for (auto _ : state) {
    CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
    if (!r.status.HasResult()) {
      state.SkipWithError(r.status.message.c_str());
      return;
    }
    iterations = r.outer_iterations;
    benchmark::DoNotOptimize(r);
  }
  state.counters["samples"] = static_cast<double>(f.sim.imu.size());
  state.counters["recording_s"] = f.duration_s;
  state.counters["outer_iterations"] = iterations;
  state.counters["items_per_second"] = benchmark::Counter(
      static_cast<double>(f.sim.imu.size()), benchmark::Counter::kIsIterationInvariantRate);
  // (wall time per calibration) / (recording duration) and / (10 s target): an
  // iteration-invariant rate of v per second, inverted, is seconds-per-iteration / v.
  state.counters["calib_s_per_recording_s"] = benchmark::Counter(
      f.duration_s, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["fraction_of_10s_target"] = benchmark::Counter(
      10.0, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  imubench::bench::reportPeakRss(state);
}
BENCHMARK(BM_IndirectCalibration12Run2kHz)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(3);

void BM_BenchPipeline2kHz(benchmark::State& state) {
  const Fixture& nav = fixture();
  const Fixture& direct = directFixture();
  if (!nav.ok || !direct.ok) {
    state.SkipWithError("could not load/expand/simulate the plans");
    return;
  }
  BenchCalibrationInput in;
  in.direct.site.latitude_rad = 58.0 * kDegToRad;
  in.direct.site.height_m = 100.0;
  in.direct.imu = direct.sim.imu;
  in.direct.table = direct.sim.table;
  in.direct.segments = direct.sim.segments;
  in.navigation.push_back({nav.sim.imu, nav.sim.table, nav.sim.segments});
  int passes = 0;
  for (auto _ : state) {
    BenchCalibrationResult r = calibrateBench(in);
    if (!r.status.HasResult()) {
      state.SkipWithError(r.status.message.c_str());
      return;
    }
    passes = r.passes;
    benchmark::DoNotOptimize(r);
  }
  const double recorded = nav.duration_s + direct.duration_s;
  state.counters["samples"] = static_cast<double>(nav.sim.imu.size() + direct.sim.imu.size());
  state.counters["recording_s"] = recorded;
  state.counters["passes"] = passes;
  state.counters["calib_s_per_recording_s"] = benchmark::Counter(
      recorded, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["fraction_of_10s_target"] = benchmark::Counter(
      10.0, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  imubench::bench::reportPeakRss(state);
}
BENCHMARK(BM_BenchPipeline2kHz)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
