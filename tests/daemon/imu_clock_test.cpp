// ImuClockMap: wall-clock instants onto the IMU's sample clock through the least-delayed
// anchors, whatever the receive jitter, at a real bench's rate (1) and a virtual bench's (20).
#include "daemon/imu_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace imubench::daemon {
namespace {

// A sender that batches: every `period_s` of wall time it sends the samples due so far; each
// burst's last sample is received `delay` later (a fixed latency plus exponential jitter).
struct BurstStream {
  double scale = 1.0;       // IMU seconds per wall second
  double t0_unix = 1.7e9;   // wall instant of IMU time 0
  double sample_s = 0.005;  // IMU sample period
  double period_s = 0.001;  // wall time between bursts
  double latency_s = 2e-4;  // least receive delay
  double jitter_s = 2e-3;   // mean of the extra (exponential) delay
  std::mt19937 rng{7};

  // Feeds bursts from wall time a to b; returns nothing, the map holds the anchors.
  void feed(ImuClockMap* map, double a, double b) {
    std::exponential_distribution<double> extra(1.0 / jitter_s);
    for (double w = a; w < b; w += period_s) {
      const double due = std::floor((w - t0_unix) * scale / sample_s) * sample_s;
      map->addAnchor(w + latency_s + extra(rng), due);
    }
  }
  double imuAt(double unix_s) const { return (unix_s - t0_unix) * scale; }
};

TEST(ImuClockMap, NothingUntilTheAnchorsSpanTheWindowsFraction) {
  ImuClockMap map;
  EXPECT_FALSE(map.imuTime(1.7e9));
  map.addAnchor(1.7e9, 0.0);
  map.addAnchor(1.7e9 + 0.01, 0.01);
  EXPECT_FALSE(map.imuTime(1.7e9)) << "two anchors 10 ms apart give no slope worth using";
}

// sample_s: the IMU's sample period; the sender sends a burst every ms of wall time.
void expectTracksTheClock(double scale, double sample_s) {
  BurstStream s;
  s.scale = scale;
  s.sample_s = sample_s;
  ImuClockMap map;
  s.feed(&map, s.t0_unix, s.t0_unix + 3.0);
  double worst = 0.0;
  for (double w = s.t0_unix + 2.0; w < s.t0_unix + 3.0; w += 0.0137) {
    const auto t = map.imuTime(w);
    ASSERT_TRUE(t);
    worst = std::max(worst, std::abs(*t - s.imuAt(w)) / scale);  // in wall seconds
  }
  // Receive jitter of 2 ms mean (up to ~15 ms) reaches the map as the least delay (0.2 ms)
  // and the sample grid (one sample of IMU time), not as the jitter.
  EXPECT_LT(worst, s.latency_s + s.sample_s / scale + 2e-4) << "scale " << scale;
}

TEST(ImuClockMap, RealBenchRateIgnoresReceiveJitter) {
  expectTracksTheClock(1.0, 0.001);
}
TEST(ImuClockMap, VirtualBenchRateIgnoresReceiveJitter) {
  expectTracksTheClock(20.0, 0.005);
}

TEST(ImuClockMap, ARestartOfTheSampleClockStartsAfresh) {
  BurstStream s;
  s.sample_s = 0.001;
  ImuClockMap map;
  s.feed(&map, s.t0_unix, s.t0_unix + 2.0);
  ASSERT_TRUE(map.imuTime(s.t0_unix + 1.9));
  s.t0_unix += 2.0;  // the IMU restarts at t = 0, two seconds on
  s.feed(&map, s.t0_unix, s.t0_unix + 0.1);
  EXPECT_FALSE(map.imuTime(s.t0_unix + 0.05)) << "the old line must not answer for the new clock";
  s.feed(&map, s.t0_unix + 0.1, s.t0_unix + 1.5);
  const auto t = map.imuTime(s.t0_unix + 1.4);
  ASSERT_TRUE(t);
  EXPECT_NEAR(*t, s.imuAt(s.t0_unix + 1.4), 0.01);
}

}  // namespace
}  // namespace imubench::daemon
