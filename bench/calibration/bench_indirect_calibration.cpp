// Navigation-based (indirect) calibration of a 2 kHz recording of the bundled two-axis 12-run
// plan (plans/library/two_axis_12run.toml), navigation-grade noise and table errors. Target:
// the full calibration in < 10 s on one core. Reports seconds per calibration, the ratio to
// the recording's duration and to the 10 s target.
// Also the whole production pipeline (calib/bench_calibration.h) at 2 kHz: direct calibration
// of the direct plan's recording, refinement over both recordings, and the second pass a
// nonorthogonal table needs.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "calib/bench_calibration.h"
#include "calib/indirect_calibration.h"
#include "calib/simulator.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace {

using namespace imubench;
using namespace imubench::calib;

struct Fixture {
  Simulation sim;
  double duration_s = 0.0;
  bool ok = false;
};

Fixture simulatePlan(const char* name) {
  Fixture out;
  const std::string path = std::string(IMUBENCH_PLAN_DIR) + "/" + name + ".toml";
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  if (!plan || !plans::validatePlan(*plan, diag)) {
    std::fprintf(stderr, "plan %s: %s\n", path.c_str(), diag.str().c_str());
    return out;
  }
  const plans::ExpandResult e = plans::expand(*plan);
  if (!e.ok) return out;
  SimulatorInput si;
  si.world.site.latitude_rad = 58.0 * kDegToRad;
  si.world.site.height_m = 100.0;
  si.world.noise.gyro.white = 0.002 * kDegToRad / 60.0;
  si.world.noise.accel.white = 20.0 * 9.80665e-6;
  BenchTruth& t = si.world.truth;
  t.sensors.accel.scale = Vec3(1.0002, 0.9997, 1.0001);
  t.sensors.gyro.scale = Vec3(0.9998, 1.0003, 1.0001);
  t.sensors.accel.bias = Vec3(50, -50, 50) * 9.80665e-6;
  t.sensors.gyro.bias = Vec3(-0.01, 0.01, 0.01) * kDegPerHourToRadPerSec;
  t.sensors.accel.mis = {1e-4, -2e-4, 3e-4, -1e-4, 2e-4, -3e-4};
  t.sensors.gyro.mis = {-2e-4, 1e-4, -3e-4, 2e-4, -1e-4, 3e-4};
  t.table.base_tilt = Vec2(40, -25) * kArcsecToRad;
  t.table.mounting = Vec2(-30, 50) * kArcsecToRad;
  t.table.nonorthogonality.inner_y = 35 * kArcsecToRad;
  si.motion = e.motion;
  SimOptions so;
  so.imu_rate_hz = 2000.0;
  so.table_rate_hz = 100.0;
  out.sim = simulate(si, so);
  out.duration_s = e.motion.duration;
  out.ok = out.sim.ok;
  return out;
}

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
    if (!r.ok) {
      state.SkipWithError(r.error.c_str());
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
    if (!r.ok) {
      state.SkipWithError(r.error.c_str());
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
}
BENCHMARK(BM_BenchPipeline2kHz)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
