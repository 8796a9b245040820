// Tests on a virtual CAN bus (vcan0). ctest runs every case through tools/vcan-run.sh, which
// provides vcan0 on the host or inside user-mode-linux; without vcan0 these tests FAIL.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include "drivers/imu_can_reader.h"
#include "drivers/virtual_imu_can.h"
#include "tests/can/can_test_util.h"
#include "tests/can/child_process.h"

extern char** environ;

namespace imubench::drivers {
namespace {

using testing::expectSameWithinResolution;
using testing::loadShipped;
using testing::makeSamples;

constexpr const char* kIf = "vcan0";

// Receivers registered on vcan0 (raw sockets show up in /proc/net/can/rcvlist_all).
int vcanReceivers() {
  std::ifstream in("/proc/net/can/rcvlist_all");
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string first;
    ss >> first;
    if (first == kIf) ++n;
  }
  return n;
}

// Waits (polling kernel state, bounded) until vcan0 has at least `count` receivers.
bool waitForReceivers(int count, int timeout_ms = 20000) {
  for (int waited = 0; waited < timeout_ms; waited += 5) {
    if (vcanReceivers() >= count) return true;
    poll(nullptr, 0, 5);
  }
  return false;
}

using testing::spawnChild;
using testing::waitChild;

// Reads until `want` samples arrived or no frame came for idle_ms.
std::vector<DecodedImuSample> readSamples(ImuCanReader& reader, std::size_t want,
                                          int idle_ms = 3000) {
  std::vector<DecodedImuSample> out;
  while (out.size() < want) {
    const auto frames_before = reader.framesReceived();
    Status st = reader.poll(idle_ms, &out);
    EXPECT_TRUE(st.ok) << st.message;
    if (!st.ok || reader.framesReceived() == frames_before) break;
  }
  return out;
}

ImuCanReaderOptions readerOptions() {
  ImuCanReaderOptions o;
  o.interface = kIf;
  return o;
}

VirtualImuOptions imuOptions(const VirtualImuFaults& faults = VirtualImuFaults{}) {
  VirtualImuOptions o;
  o.interface = kIf;
  o.faults = faults;
  return o;
}

std::string tempPath(const std::string& name) {
  return testing::scratchPath(name);
}

class VcanStream : public ::testing::TestWithParam<const char*> {};

// The virtual IMU streams simulator-like samples in per-tick batches; the reader decodes them
// with zero loss and identical to the source within the layout's resolution.
TEST_P(VcanStream, ZeroLossWithinResolution) {
  const ImuLayout layout = loadShipped(GetParam());
  const int n = layout.messages.size() == 1 ? 20000 : 6000;
  const auto samples = makeSamples(n, layout.sample_period_s, 11);
  ImuCanReader reader(layout, readerOptions());
  ASSERT_TRUE(reader.open().ok);
  VirtualImuCan imu(layout, imuOptions());
  Status st = imu.open();
  ASSERT_TRUE(st.ok) << st.message;
  std::vector<DecodedImuSample> got;
  const std::size_t tick = 100;  // samples per tick: one sendmmsg batch
  for (std::size_t k = 0; k < samples.size(); k += tick) {
    const std::size_t m = std::min(tick, samples.size() - k);
    st = imu.sendSamples(std::span(samples).subspan(k, m));
    ASSERT_TRUE(st.ok) << st.message;
    while (reader.framesReceived() < imu.framesSent()) {
      const auto before = reader.framesReceived();
      ASSERT_TRUE(reader.poll(2000, &got).ok);
      ASSERT_GT(reader.framesReceived(), before) << "frames stopped arriving";
    }
  }
  const auto& c = reader.decoder().counters();
  std::cout << GetParam() << ": frames " << c.frames << " samples " << c.samples << " lost "
            << c.lost_samples << " bad " << c.badFrames() << " kernel drops "
            << reader.socket().kernelDrops() << "\n";
  EXPECT_EQ(c.lost_samples, 0U);
  EXPECT_EQ(c.badFrames(), 0U);
  EXPECT_EQ(c.incomplete, 0U);
  EXPECT_EQ(reader.socket().kernelDrops(), 0U);
  expectSameWithinResolution(layout, samples, got);
  // Kernel receive time stamps are present and non-decreasing.
  for (std::size_t k = 1; k < got.size(); ++k) ASSERT_GE(got[k].rx_time_s, got[k - 1].rx_time_s);
  EXPECT_GT(got.front().rx_time_s, 1.0);
}

INSTANTIATE_TEST_SUITE_P(Layouts, VcanStream,
                         ::testing::Values("sbg_ecan.toml", "navgrade_fd.toml", "sbg_ecan_dbc.toml",
                                           "navgrade_fd_dbc.toml"));

TEST(VcanFaults, DroppedCorruptedBadStatusAndStoppedImu) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const auto samples = makeSamples(2000, layout.sample_period_s, 3);
  ImuCanReader reader(layout, readerOptions());
  ASSERT_TRUE(reader.open().ok);
  VirtualImuFaults faults;
  faults.drop_frame_every = 100;
  faults.corrupt_frame_every = 40;
  faults.stop_after = 1500;
  VirtualImuCan imu(layout, imuOptions(faults));
  ASSERT_TRUE(imu.open().ok);
  ASSERT_TRUE(imu.sendSamples(samples).ok);
  EXPECT_TRUE(imu.stopped());
  auto got = readSamples(reader, 2000, 1500);
  const auto& c = reader.decoder().counters();
  std::cout << "faults: samples " << c.samples << " lost " << c.lost_samples << " bad length "
            << c.bad_length << " unknown id " << c.unknown_id
            << " last problem: " << reader.decoder().lastProblem() << "\n";
  // 1500 sent: 15 dropped (k+1 = 100, 200, ..., 1500), 37 corrupted (40, 80, ..., 1480), 7 both
  // (200, ..., 1400; dropped, so not seen as bad): 45 missing samples; 44 are followed by a
  // good sample and show as counter gaps, the last (1500) is not.
  EXPECT_EQ(got.size(), 1500U - 45U);
  EXPECT_EQ(c.bad_length + c.unknown_id, 37U - 7U);
  EXPECT_EQ(c.lost_samples, 44U);
  EXPECT_EQ(imu.samplesEncoded(), 1500U);  // the IMU stopped: nothing after sample 1500
}

// candump -L captures the virtual IMU's traffic; canplayer replays the log into the reader,
// which decodes exactly what it decoded live.
class Interop : public ::testing::TestWithParam<const char*> {};

TEST_P(Interop, CandumpLogReplayedByCanplayerDecodesIdentically) {
  const ImuLayout layout = loadShipped(GetParam());
  const auto samples = makeSamples(300, layout.sample_period_s, 5);
  const std::size_t frames = samples.size() * layout.messages.size();
  const std::string log = tempPath("candump.log");

  ImuCanReader live(layout, readerOptions());
  ASSERT_TRUE(live.open().ok);
  const int base = vcanReceivers();
  const pid_t dump =
      spawnChild({"candump", "-L", "-r", "16777216", "-n", std::to_string(frames), kIf}, log);
  ASSERT_GT(dump, 0) << "cannot start candump (package can-utils)";
  ASSERT_TRUE(waitForReceivers(base + 1)) << "candump did not open its socket";
  VirtualImuCan imu(layout, imuOptions());
  ASSERT_TRUE(imu.open().ok);
  // Per-tick batches; after each, wait until the live reader has them (candump got them too).
  std::vector<DecodedImuSample> live_samples;
  for (std::size_t k = 0; k < samples.size(); k += 50) {
    ASSERT_TRUE(imu.sendSamples(
                       std::span(samples).subspan(k, std::min<std::size_t>(50, samples.size() - k)))
                    .ok);
    while (live.framesReceived() < imu.framesSent()) {
      const auto before = live.framesReceived();
      ASSERT_TRUE(live.poll(2000, &live_samples).ok);
      ASSERT_GT(live.framesReceived(), before) << "frames stopped arriving";
    }
  }
  ASSERT_EQ(waitChild(dump, 20000), 0) << "candump did not capture " << frames << " frames";
  expectSameWithinResolution(layout, samples, live_samples);

  // The log is candump's own text format: "(time) vcan0 120#..." or "##" for FD.
  std::ifstream in(log);
  std::string first;
  std::getline(in, first);
  EXPECT_NE(first.find(layout.messages[0].fd ? "##" : "#"), std::string::npos) << first;
  std::cout << "candump log line: " << first << "\n";

  ImuCanReader replay(layout, readerOptions());
  ASSERT_TRUE(replay.open().ok);
  const pid_t player = spawnChild({"canplayer", "-t", "-g", "0", "-I", log}, "");
  ASSERT_GT(player, 0) << "cannot start canplayer";
  ASSERT_EQ(waitChild(player, 60000), 0);
  const auto replayed = readSamples(replay, samples.size());
  ASSERT_EQ(replayed.size(), live_samples.size());
  for (std::size_t k = 0; k < replayed.size(); ++k) {
    ASSERT_EQ(replayed[k].sample.t, live_samples[k].sample.t) << k;
    ASSERT_EQ(replayed[k].sample.dtheta, live_samples[k].sample.dtheta) << k;
    ASSERT_EQ(replayed[k].sample.dvel, live_samples[k].sample.dvel) << k;
    ASSERT_EQ(replayed[k].sample.temp_c, live_samples[k].sample.temp_c) << k;
  }
  EXPECT_EQ(replay.decoder().counters().lost_samples, 0U);
  EXPECT_EQ(replay.decoder().counters().badFrames(), 0U);
  std::remove(log.c_str());
}

INSTANTIATE_TEST_SUITE_P(Layouts, Interop, ::testing::Values("sbg_ecan.toml", "navgrade_fd.toml"));

// Frames typed with cansend (wrong length, unknown id) are counted and the stream goes on.
TEST(InteropCansend, BadLengthAndUnknownIdCountedNotFatal) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const auto samples = makeSamples(20, layout.sample_period_s, 9);
  ImuCanReader reader(layout, readerOptions());
  ASSERT_TRUE(reader.open().ok);
  VirtualImuCan imu(layout, imuOptions());
  ASSERT_TRUE(imu.open().ok);
  ASSERT_TRUE(imu.sendSamples(std::span(samples).first(10)).ok);
  EXPECT_EQ(waitChild(spawnChild({"cansend", kIf, "121#0102"}, ""), 10000), 0);  // accel, 2 bytes
  EXPECT_EQ(waitChild(spawnChild({"cansend", kIf, "7FF#00"}, ""), 10000), 0);    // unknown id
  EXPECT_EQ(waitChild(spawnChild({"cansend", kIf, "120#11223344"}, ""), 10000),
            0);  // info, 4 bytes
  ASSERT_TRUE(imu.sendSamples(std::span(samples).subspan(10)).ok);
  const auto got = readSamples(reader, 20);
  const auto& c = reader.decoder().counters();
  std::cout << "cansend: bad length " << c.bad_length << " unknown id " << c.unknown_id
            << " last problem: " << reader.decoder().lastProblem() << "\n";
  EXPECT_EQ(c.bad_length, 2U);
  EXPECT_EQ(c.unknown_id, 1U);
  EXPECT_EQ(c.lost_samples, 0U);
  expectSameWithinResolution(layout, samples, got);
}

}  // namespace
}  // namespace imubench::drivers
