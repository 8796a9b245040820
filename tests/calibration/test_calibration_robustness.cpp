// External input never crashes the calibrators: random, malformed and hostile recordings
// (segments out of order, reversed, overlapping, beyond the data, naming no axis; table
// samples missing or out of range; IMU samples with jumps) go through the direct,
// navigation-based and pipeline calibrations, which must return either a result or a reason.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calib/indirect/bench_calibration.h"

namespace imubench::calib {
namespace {

struct RandomRecording {
  nav::ImuSamples imu;
  std::vector<TableSample> table;
  std::vector<Segment> segments;
};

RandomRecording randomRecording(std::mt19937_64& rng, TableKind kind) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> small(0, 40);
  RandomRecording r;
  const double rate = u(rng) < 0.5 ? 10.0 : 100.0;
  const int n = small(rng) * 25;  // 0 .. 1000 samples
  double t = u(rng) * 10.0;
  for (int k = 0; k < n; ++k) {
    t += (u(rng) < 0.02 ? 5.0 : 1.0) / rate;  // occasional gap
    nav::ImuSample s;
    s.t = t;
    s.dtheta = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * (u(rng) < 0.3 ? 0.5 : 1e-5);
    s.dvel = Vec3(0.0, 0.0, 9.8 / rate) + Vec3(u(rng), u(rng), u(rng)) * 1e-3;
    r.imu.push_back(s);
  }
  const int m = small(rng);
  for (int k = 0; k < m; ++k) {
    TableSample ts;
    ts.t = u(rng) * (t + 5.0) - 2.0;  // unsorted, possibly outside the IMU span
    ts.angles = {(u(rng) - 0.5) * 20.0, (u(rng) - 0.5) * 20.0, (u(rng) - 0.5) * 20.0};
    r.table.push_back(ts);
  }
  if (u(rng) < 0.5) {
    std::sort(r.table.begin(), r.table.end(),
              [](const TableSample& a, const TableSample& b) { return a.t < b.t; });
  }
  const int segs = small(rng);
  for (int k = 0; k < segs; ++k) {
    Segment s;
    s.t0 = u(rng) * (t + 20.0) - 5.0;
    s.t1 = s.t0 + (u(rng) - 0.2) * 60.0;  // sometimes reversed
    s.kind = u(rng) < 0.5 ? SegmentKind::kStatic : SegmentKind::kRotate;
    s.axis = static_cast<int>(u(rng) * 5.0) - 1;  // -1 .. 3: sometimes no such axis
    s.angle = (u(rng) - 0.5) * 8.0;
    s.recording = u(rng) < 0.9;
    s.label = "s" + std::to_string(k);
    r.segments.push_back(s);
  }
  (void)kind;
  return r;
}

TEST(CalibrationRobustness, RandomRecordingsGiveAResultOrAReason) {
  std::mt19937_64 rng(2026);
  int refused = 0, calibrated = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const TableKind kind = trial % 2 == 0 ? TableKind::kTwoAxis : TableKind::kThreeAxis;
    const RandomRecording a = randomRecording(rng, kind);
    const RandomRecording b = randomRecording(rng, kind);
    DirectCalibrationInput din;
    din.geometry.kind = kind;
    din.imu = a.imu;
    din.table = a.table;
    din.segments = a.segments;
    const DirectCalibrationResult d = calibrateDirect(din);
    EXPECT_TRUE(d.status.HasResult() || !d.status.message.empty()) << "trial " << trial;

    IndirectInput in;
    in.geometry.kind = kind;
    in.imu = b.imu;
    in.table = b.table;
    in.segments = b.segments;
    in.extra_legs.push_back({a.imu, a.table, a.segments});
    const CalibrationResult r = calibrateIndirect(in, IndirectOptions{});
    EXPECT_TRUE(r.status.HasResult() || !r.status.message.empty()) << "trial " << trial;

    BenchCalibrationInput bin;
    bin.direct = viewOf(din);
    bin.navigation.push_back({b.imu, b.table, b.segments});
    const BenchCalibrationResult p = calibrateBench(bin);
    EXPECT_TRUE(p.status.HasResult() || !p.status.message.empty()) << "trial " << trial;
    refused += (d.status.HasResult() ? 0 : 1) + (r.status.HasResult() ? 0 : 1) +
               (p.status.HasResult() ? 0 : 1);
    calibrated += (d.status.HasResult() ? 1 : 0) + (r.status.HasResult() ? 1 : 0) +
                  (p.status.HasResult() ? 1 : 0);
  }
  RecordProperty("refused", refused);
  RecordProperty("calibrated", calibrated);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace imubench::calib
