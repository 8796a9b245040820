// Simulator throughput: IMU samples per second on one core (target >= 2 M/s).
#include <benchmark/benchmark.h>

#include "bench/peak_rss.h"
#include "calib/simulator.h"

namespace imubench::calib {
namespace {

BenchWorld world(bool noisy, bool effects) {
  BenchWorld w;
  w.site.latitude_rad = 55.75 * kDegToRad;
  w.truth.sensors.accel.scale = Vec3(1.0001, 0.9999, 1.00002);
  w.truth.sensors.accel.mis = {1e-4, 2e-4, -1e-4, 3e-4, -2e-4, 1e-4};
  w.truth.sensors.gyro.bias = Vec3(1e-7, -2e-7, 3e-7);
  w.truth.table.base_tilt = Vec2(1e-4, -5e-5);
  w.truth.table.mounting = Vec2(2e-4, 1e-4);
  if (noisy) w.noise = NoiseModel::navigationGrade();
  if (effects) {
    w.truth.extra.lever_arm = LeverArm{Vec3(0.05, 0.02, -0.03)};
    w.truth.extra.thermal_bias = ThermalBias{Vec3::Constant(1e-5), Vec3::Constant(1e-9), 20.0};
    w.truth.extra.time_delay = TimeDelay{1e-3};
  }
  return w;
}

// Both axes turning (the expensive case: 3 quadrature nodes per sample), or still.
Motion motion(bool moving) {
  Motion m;
  m.kind = TableKind::kTwoAxis;
  m.axes.resize(2);
  m.axes[0].append({0.0, 0.1, moving ? 0.3 : 0.0, 0.0});
  m.axes[1].append({0.0, 0.2, moving ? 1.0 : 0.0, 0.0});
  m.duration = 1e9;
  return m;
}

void BM_ImuSimulator(benchmark::State& state) {
  const bool moving = state.range(0) != 0;
  const bool noisy = state.range(1) != 0;
  const bool effects = state.range(2) != 0;
  const Motion m = motion(moving);
  SimOptions o;
  o.imu_rate_hz = 1000.0;
  std::string why;
  auto sim = ImuSimulator::Create(world(noisy, effects), &m, o, &why);
  if (!sim) {
    state.SkipWithError(why.c_str());
    return;
  }
  for (auto _ : state) {
    nav::ImuSample s = sim->next();
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations());
  imubench::bench::reportPeakRss(state);
}
BENCHMARK(BM_ImuSimulator)
    ->ArgNames({"moving", "noise", "effects"})
    ->Args({0, 0, 0})
    ->Args({1, 0, 0})
    ->Args({1, 1, 0})
    ->Args({1, 1, 1});

}  // namespace
}  // namespace imubench::calib
