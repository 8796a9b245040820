// CAN IMU benchmarks. Decode: raw frames -> samples on one core (target >= 5 M frames/s, over
// 500x the ~9,000 frames/s ceiling of classic CAN at 1 Mbit/s). VcanStream: the virtual IMU
// streaming over vcan0 (run it through tools/vcan-run.sh: user-mode-linux when the host has no
// vcan) with the reader's CPU time per frame and the loss count.
#include <benchmark/benchmark.h>
#include <net/if.h>
#include <time.h>

#include "drivers/imu_can_reader.h"
#include "drivers/imu_decoder.h"
#include "drivers/imu_encoder.h"
#include "drivers/virtual_imu_can.h"

namespace imubench::drivers {
namespace {

ImuLayout load(const char* name) {
  const std::string path = std::string(IMUBENCH_IMU_DEVICE_DIR) + "/" + name;
  io::Diagnostics diag(path);
  auto l = loadImuLayoutFile(path, diag);
  if (!l) std::abort();  // shipped file: our bug
  return *l;
}

nav::ImuSamples samples(int n, double dt) {
  nav::ImuSamples out(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    auto& s = out[static_cast<std::size_t>(k)];
    s.t = (k + 1) * dt;
    s.dtheta = Vec3(0.01 * std::sin(k * 1e-3), 0.02, -0.03) * dt;
    s.dvel = Vec3(0.1, -0.2, 9.8) * dt;
    s.temp_c = 25.0;
  }
  return out;
}

double threadCpu() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void BM_Decode(benchmark::State& state, const char* file) {
  const ImuLayout layout = load(file);
  const auto in = samples(10000, layout.sample_period_s);
  ImuEncoder enc(layout);
  std::vector<CanFrame> frames;
  for (std::size_t k = 0; k < in.size(); ++k) enc.encode(in[k], k, enc.goodStatus(), &frames);
  std::vector<DecodedImuSample> out;
  out.reserve(in.size());
  for (auto _ : state) {
    ImuDecoder dec(layout);
    out.clear();
    dec.feed(frames, &out);
    benchmark::DoNotOptimize(out.data());
    if (dec.counters().lost_samples != 0) state.SkipWithError("decode lost samples");
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(frames.size()));
  state.counters["frames_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(frames.size()),
      benchmark::Counter::kIsRate);
  state.counters["s_per_frame"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(frames.size()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK_CAPTURE(BM_Decode, navgrade_fd, "navgrade_fd.toml");
BENCHMARK_CAPTURE(BM_Decode, sbg_ecan, "sbg_ecan.toml");
BENCHMARK_CAPTURE(BM_Decode, sbg_ecan_dbc, "sbg_ecan_dbc.toml");

// Streams 100k frames per iteration through vcan0 in per-tick batches (one sendmmsg each),
// the reader draining with recvmmsg after each tick.
void BM_VcanStream(benchmark::State& state, const char* file) {
  if (if_nametoindex("vcan0") == 0) {
    state.SkipWithError("no vcan0: run through tools/vcan-run.sh");
    return;
  }
  const ImuLayout layout = load(file);
  const int per_tick = static_cast<int>(state.range(0));
  const int frames_per_sample = static_cast<int>(layout.messages.size());
  const int n = 100000 / frames_per_sample;
  const auto in = samples(n, layout.sample_period_s);
  double reader_cpu = 0.0;
  std::uint64_t frames = 0;
  std::uint64_t lost = 0;
  std::uint64_t delivered = 0;
  for (auto _ : state) {
    ImuCanReaderOptions ro;
    ro.interface = "vcan0";
    ImuCanReader reader(layout, ro);
    VirtualImuOptions vo;
    vo.interface = "vcan0";
    VirtualImuCan imu(layout, vo);
    if (!reader.open().ok || !imu.open().ok) {
      state.SkipWithError("cannot open vcan0");
      return;
    }
    std::vector<DecodedImuSample> got;
    got.reserve(in.size());
    for (std::size_t k = 0; k < in.size(); k += static_cast<std::size_t>(per_tick)) {
      const auto m = std::min<std::size_t>(static_cast<std::size_t>(per_tick), in.size() - k);
      if (!imu.sendSamples(std::span(in).subspan(k, m)).ok) state.SkipWithError("send failed");
      const double c0 = threadCpu();
      while (reader.framesReceived() < imu.framesSent()) {
        const auto before = reader.framesReceived();
        if (!reader.poll(2000, &got).ok || reader.framesReceived() == before) break;
      }
      reader_cpu += threadCpu() - c0;
    }
    frames += reader.framesReceived();
    lost += reader.decoder().counters().lost_samples + (in.size() - got.size());
    delivered += got.size();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  state.counters["reader_cpu_ns_per_frame"] = 1e9 * reader_cpu / static_cast<double>(frames);
  state.counters["lost_samples"] = static_cast<double>(lost);
  state.counters["samples"] = static_cast<double>(delivered);
}
BENCHMARK_CAPTURE(BM_VcanStream, navgrade_fd, "navgrade_fd.toml")
    ->Arg(256)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_VcanStream, sbg_ecan, "sbg_ecan.toml")
    ->Arg(100)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

}  // namespace
}  // namespace imubench::drivers
