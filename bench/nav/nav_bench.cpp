// nav/ throughput: one insMech step, and free navigation of a 1 h recording at 2 kHz.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "bench/peak_rss.h"
#include "nav/free_navigation.h"
#include "nav/strapdown.h"

namespace imubench::nav {
namespace {

constexpr double kLat = 58.0 * kDegToRad;

// Increments of a turn at 20 deg/s about a tilted axis with gravity and Earth rate (first
// order is enough here: only the work per step matters), a ring of distinct samples so the
// compiler cannot hoist anything out of the loop.
std::vector<ImuSample> turnRing(double rate_hz, std::size_t n) {
  std::vector<ImuSample> ring(n);
  const double dt = 1.0 / rate_hz;
  const Vec3 axis = Vec3(0.3, 1.0, 0.2).normalized();
  const double w = 20.0 * kDegToRad;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k + 1) * dt;
    const Mat3 C_BL = Eigen::AngleAxisd(-w * t, axis).toRotationMatrix();
    ring[k].t = t;
    ring[k].dtheta = (w * axis + C_BL * earthRateL(kLat)) * dt;
    ring[k].dvel = C_BL * Vec3(0.0, 0.0, normalGravity(kLat, 100.0)) * dt;
  }
  return ring;
}

void BM_InsMech(benchmark::State& state) {
  const double rate_hz = 2000.0;
  const std::vector<ImuSample> ring = turnRing(rate_hz, 4096);
  const double dt = 1.0 / rate_hz;
  const MechOptions opt;
  NavState s;
  s.lat_rad = kLat;
  s.height_m = 100.0;
  ImuSample prev;
  ImuSample cur;
  std::size_t i = 0;
  for (auto _ : state) {
    cur = ring[i];
    cur.t = s.t + dt;
    s = insMech(s, prev, cur, opt);
    prev = cur;
    if (++i == ring.size()) i = 0;
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["x_5M_target"] = benchmark::Counter(static_cast<double>(state.iterations()) / 5e6,
                                                     benchmark::Counter::kIsRate);
  imubench::bench::reportPeakRss(state);
}
BENCHMARK(BM_InsMech);

// Free navigation (streaming form, the path navigateFree uses) of 1 h at 2 kHz: 7.2 M samples
// generated on the fly (a stored 1 h recording would be 460 MB), output every 1 s.
void BM_FreeNav1h2kHz(benchmark::State& state) {
  const double rate_hz = 2000.0;
  const long n = static_cast<long>(3600.0 * rate_hz);
  const double dt = 1.0 / rate_hz;
  const Mat3 C_LB = Rz(0.3) * Rx(0.01) * Ry(-0.02);
  const Vec3 w_B = C_LB.transpose() * earthRateL(kLat) + Vec3(1e-8, -2e-8, 3e-8);
  const Vec3 f_B =
      C_LB.transpose() * Vec3(0.0, 0.0, normalGravity(kLat, 100.0)) + Vec3(5e-4, -5e-4, 1e-4);
  const Site site{kLat, 100.0, std::nullopt};
  FreeNavOptions opt;
  std::size_t outputs = 0;
  for (auto _ : state) {
    FreeNavigator nav(stationaryState(0.0, Quat(C_LB), site), opt);
    ImuSample s;
    for (long k = 1; k <= n; ++k) {
      s.t = static_cast<double>(k) * dt;
      s.dtheta = w_B * dt;
      s.dvel = f_B * dt;
      if (nav.feed(s).output) ++outputs;
    }
    benchmark::DoNotOptimize(nav.state());
  }
  state.SetItemsProcessed(state.iterations() * n);
  state.counters["outputs"] =
      static_cast<double>(outputs) / static_cast<double>(state.iterations());
  // Seconds of recording navigated per second of wall time.
  state.counters["realtime_ratio"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * 3600.0, benchmark::Counter::kIsRate);
  imubench::bench::reportPeakRss(state);
}
BENCHMARK(BM_FreeNav1h2kHz)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace imubench::nav
