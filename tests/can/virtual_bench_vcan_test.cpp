// The virtual bench program (imubench-virtual-bench) streams its simulated IMU on vcan0; the
// drivers' ImuCanReader decodes the frames and every sample must equal, one by one, the sample
// calib::ImuSimulator produces in-process for the identical world (default site, truth file,
// noise model and seed, the layout's rate, the table left stationary at zero angles, the
// chamber at ambient), within the layout's resolution, with zero lost samples. ctest runs
// every case through tools/vcan-run.sh (host vcan0 or user-mode-linux); without vcan0 it FAILS.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "calib/simulator.h"
#include "drivers/imu_can_reader.h"
#include "drivers/imu_layout.h"
#include "io/truth_file.h"
#include "scratch_dir.h"
#include "tests/can/child_process.h"

extern char** environ;

namespace imubench::drivers {
namespace {

constexpr const char* kIf = "vcan0";
constexpr std::size_t kSamples = 2000;
constexpr std::uint64_t kSeed = 20261123;
constexpr const char* kNoise = "tactical";  // noise comparable to the quantum: seed matters
constexpr double kAmbientC = 20.0;          // virtual bench default (--ambient)

std::string devicePath(const std::string& rel) {
  return std::string(IMUBENCH_DEVICE_DIR) + "/" + rel;
}
std::string truthPath() {
  return std::string(IMUBENCH_TEST_TRUTH);
}

std::string tempPath(const std::string& name) {
  return testing::scratchPath(name);
}

// Sends SIGTERM and waits for the exit (bounded; SIGKILL after the timeout). Returns the exit
// code, or -1 when it had to be killed or died by a signal.
int stopChild(pid_t pid, int timeout_ms = 10000) {
  kill(pid, SIGTERM);
  return testing::waitChild(pid, timeout_ms);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The samples the virtual bench's simulator produces for a stationary table: same world,
// options and Motion the program builds (drivers/virtual_world.h: every axis holds a phase at
// t = 0 with zero angle and rate; the chamber history is ambient).
nav::ImuSamples expectedSamples(const ImuLayout& layout, std::size_t n) {
  calib::BenchWorld world;
  auto truth = io::readTruthFile(truthPath());
  EXPECT_TRUE(truth.status.ok) << truth.status.message;
  world.truth = truth.value;
  world.noise = calib::NoiseModel::tactical();
  calib::Motion motion;
  motion.kind = calib::TableKind::kTwoAxis;  // imubench-ref-2axis-tcp.toml
  motion.axes.resize(2);
  for (auto& a : motion.axes) a.append({0.0, 0.0, 0.0, 0.0});
  motion.temperature.push_back({0.0, kAmbientC});
  calib::SimOptions opts;
  opts.imu_rate_hz = 1.0 / layout.sample_period_s;
  opts.seed = kSeed;
  std::string why;
  auto sim = calib::ImuSimulator::Create(world, &motion, opts, &why);
  EXPECT_NE(sim, nullptr) << why;
  nav::ImuSamples out;
  if (!sim) return out;
  // The program's motion grows with the virtual clock; for a still table its duration is the
  // only difference, and a streaming simulator extrapolates the last phase past it.
  motion.duration = static_cast<double>(n + 1) * layout.sample_period_s;
  while (out.size() < n) out.push_back(sim->next());
  return out;
}

class VirtualBenchVcan : public ::testing::TestWithParam<const char*> {};

TEST_P(VirtualBenchVcan, SamplesEqualInProcessSimulatorWithinResolution) {
  const std::string layout_file = devicePath(std::string("imus/") + GetParam());
  io::Diagnostics diag(layout_file);
  auto loaded = loadImuLayoutFile(layout_file, diag);
  ASSERT_TRUE(loaded.has_value()) << diag.str();
  const ImuLayout& layout = *loaded;
  const nav::ImuSamples expected = expectedSamples(layout, kSamples);
  ASSERT_EQ(expected.size(), kSamples);

  // The reader listens before the program starts, so it sees sample 1 onwards.
  ImuCanReaderOptions ro;
  ro.interface = kIf;
  ImuCanReader reader(layout, ro);
  Status st = reader.open();
  ASSERT_TRUE(st.ok) << st.message;

  // About 2 s of wall time for the whole stream at either rate (100 Hz x 10, 1 kHz x 1).
  const double scale = std::max(1.0, 1.0 / (1000.0 * layout.sample_period_s));
  const std::string out_path = tempPath(std::string(GetParam()) + ".out");
  const pid_t pid = testing::spawnChild(
      {IMUBENCH_VIRTUAL_BENCH, "--table", devicePath("tables/imubench-ref-2axis-tcp.toml"),
       "--chamber", devicePath("chambers/generic-float-chamber.toml"), "--table-port", "0",
       "--chamber-port", "0", "--imu", layout_file, "--can", kIf, "--truth", truthPath(), "--noise",
       kNoise, "--seed", std::to_string(kSeed), "--time-scale", std::to_string(scale),
       // the in-process world's default site (nav::Site{})
       "--latitude", std::to_string(nav::Site{}.latitude_rad * kRadToDeg), "--height",
       std::to_string(nav::Site{}.height_m)},
      out_path, /*with_stderr=*/true);
  ASSERT_GT(pid, 0) << "cannot start " << IMUBENCH_VIRTUAL_BENCH;

  std::vector<DecodedImuSample> got;
  std::string read_error;
  while (got.size() < kSamples) {
    const auto before = reader.framesReceived();
    // Generous idle bound: the program's start-up under user-mode-linux.
    st = reader.poll(got.empty() ? 20000 : 5000, &got);
    if (!st.ok) {
      read_error = st.message;
      break;
    }
    if (reader.framesReceived() == before) {
      read_error = "no frame for 5-20 s";
      break;
    }
  }
  const int rc = stopChild(pid);
  const std::string program_out = slurp(out_path);
  std::remove(out_path.c_str());
  ASSERT_TRUE(read_error.empty()) << read_error << "\n--- program output\n" << program_out;
  EXPECT_EQ(rc, 0) << program_out;
  ASSERT_GE(got.size(), kSamples);

  const auto& c = reader.decoder().counters();
  EXPECT_EQ(c.lost_samples, 0U);
  EXPECT_EQ(c.badFrames(), 0U);
  EXPECT_EQ(c.incomplete, 0U);
  EXPECT_EQ(c.bad_status, 0U);

  // One by one, within half a quantum (ImuLayout::resolution) per component.
  const double res_t = layout.resolution(ImuQuantity::kTime);
  const double res_temp = layout.resolution(ImuQuantity::kTemperature);
  double worst_th = 0.0, worst_dv = 0.0, worst_t = 0.0, worst_temp = 0.0;  // in resolutions
  for (std::size_t k = 0; k < kSamples; ++k) {
    const nav::ImuSample& g = got[k].sample;
    const nav::ImuSample& e = expected[k];
    ASSERT_NEAR(g.t, e.t, res_t + 1e-9) << "sample " << k << " (a lost or extra sample?)";
    if (res_t > 0) worst_t = std::max(worst_t, std::abs(g.t - e.t) / res_t);
    for (int a = 0; a < 3; ++a) {
      const double res_th =
          layout.resolution(static_cast<ImuQuantity>(static_cast<int>(ImuQuantity::kDthetaX) + a));
      const double res_dv =
          layout.resolution(static_cast<ImuQuantity>(static_cast<int>(ImuQuantity::kDvelX) + a));
      ASSERT_GT(res_th, 0.0);
      ASSERT_GT(res_dv, 0.0);
      ASSERT_NEAR(g.dtheta[a], e.dtheta[a], res_th * (1 + 1e-9) + 1e-15)
          << "sample " << k << " axis " << a;
      ASSERT_NEAR(g.dvel[a], e.dvel[a], res_dv * (1 + 1e-9) + 1e-15)
          << "sample " << k << " axis " << a;
      worst_th = std::max(worst_th, std::abs(g.dtheta[a] - e.dtheta[a]) / res_th);
      worst_dv = std::max(worst_dv, std::abs(g.dvel[a] - e.dvel[a]) / res_dv);
    }
    ASSERT_NEAR(g.temp_c, e.temp_c, res_temp + 1e-12) << "sample " << k;
    if (res_temp > 0) worst_temp = std::max(worst_temp, std::abs(g.temp_c - e.temp_c) / res_temp);
  }
  std::cout << GetParam() << ": compared " << kSamples << " samples (" << got.size()
            << " received), lost " << c.lost_samples << ", bad frames " << c.badFrames()
            << "; max |decoded - simulated| / (half quantum): dtheta " << worst_th << ", dvel "
            << worst_dv << ", t " << worst_t << ", temp " << worst_temp << "\n";
}

INSTANTIATE_TEST_SUITE_P(Layouts, VirtualBenchVcan,
                         ::testing::Values("sbg_ecan.toml", "navgrade_fd.toml"), [](const auto& p) {
                           std::string n = p.param;
                           return n.substr(0, n.find('.'));
                         });

}  // namespace
}  // namespace imubench::drivers
