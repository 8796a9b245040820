// Test fixtures shared by the recording, store, simulation round-trip and run-explain tests:
// bit-exact comparison of recordings and awkward doubles for round trips (and the scratch
// directory, scratch_dir.h).
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>

#include "io/recording.h"
#include "tests/daemon/scratch_dir.h"

namespace imubench::daemon::testing {

inline bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}

// How many IMU samples differ in any bit (a NaN temperature matches a NaN); the sizes must
// be equal (checked by the caller).
inline std::size_t imuMismatches(const nav::ImuSamples& a, const nav::ImuSamples& b) {
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const nav::ImuSample& x = a[i];
    const nav::ImuSample& y = b[i];
    bool same = sameBits(x.t, y.t) &&
                (std::isnan(x.temp_c) ? std::isnan(y.temp_c) : sameBits(x.temp_c, y.temp_c));
    for (int k = 0; k < 3; ++k)
      same = same && sameBits(x.dtheta[k], y.dtheta[k]) && sameBits(x.dvel[k], y.dvel[k]);
    mismatches += same ? 0 : 1;
  }
  return mismatches;
}

// Every field of two recordings bit for bit; of the segments, the fields a segments.csv
// holds (times, kind, label). Callers that keep more (the store: segments_from_file, the
// segments' recording flag, axis and angle) check those themselves.
inline void expectSameRecording(const io::Recording& a, const io::Recording& b) {
  EXPECT_TRUE(sameBits(a.latitude_deg, b.latitude_deg));
  EXPECT_TRUE(sameBits(a.height_m, b.height_m));
  ASSERT_EQ(a.gravity_mps2.has_value(), b.gravity_mps2.has_value());
  EXPECT_TRUE(sameBits(a.gravity_mps2.value_or(0.0), b.gravity_mps2.value_or(0.0)));
  EXPECT_EQ(a.imu_serial, b.imu_serial);
  EXPECT_TRUE(sameBits(a.imu_rate_hz, b.imu_rate_hz));
  EXPECT_EQ(a.table_kind, b.table_kind);
  ASSERT_EQ(a.outer_axis_heading_deg.has_value(), b.outer_axis_heading_deg.has_value());
  EXPECT_TRUE(
      sameBits(a.outer_axis_heading_deg.value_or(0.0), b.outer_axis_heading_deg.value_or(0.0)));
  ASSERT_EQ(a.imu.size(), b.imu.size());
  EXPECT_EQ(imuMismatches(a.imu, b.imu), 0u);
  ASSERT_EQ(a.table.size(), b.table.size());
  for (std::size_t i = 0; i < a.table.size(); ++i) {
    bool same = sameBits(a.table[i].t, b.table[i].t);
    for (std::size_t k = 0; k < 3; ++k)
      same = same && sameBits(a.table[i].angles_deg[k], b.table[i].angles_deg[k]);
    ASSERT_TRUE(same) << "table sample " << i;
  }
  ASSERT_EQ(a.chamber.size(), b.chamber.size());
  for (std::size_t i = 0; i < a.chamber.size(); ++i) {
    ASSERT_TRUE(sameBits(a.chamber[i].t, b.chamber[i].t) &&
                sameBits(a.chamber[i].setpoint_c, b.chamber[i].setpoint_c) &&
                sameBits(a.chamber[i].temp_c, b.chamber[i].temp_c))
        << "chamber sample " << i;
  }
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (std::size_t i = 0; i < a.segments.size(); ++i) {
    const calib::Segment& x = a.segments[i];
    const calib::Segment& y = b.segments[i];
    EXPECT_TRUE(sameBits(x.t0, y.t0) && sameBits(x.t1, y.t1)) << "segment " << i;
    EXPECT_EQ(x.kind, y.kind);
    EXPECT_EQ(x.label, y.label);
  }
}

// Awkward doubles on purpose: random mantissas over many exponents.
class AwkwardDoubles {
 public:
  explicit AwkwardDoubles(unsigned seed) : rng_(seed) {}
  double unit() { return u_(rng_); }  // uniform in [-1, 1)
  double odd() { return std::ldexp(u_(rng_), ex_(rng_)); }

 private:
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> u_{-1.0, 1.0};
  std::uniform_int_distribution<int> ex_{-30, 5};
};

// n >= 5 IMU samples at 2000 Hz after t = 0.1 + 1/3 s with awkward increments and
// temperatures (every 7th NaN: not reported), and in samples 1-4 a negative zero, a
// subnormal, the largest double and the smallest negative normal.
inline nav::ImuSamples awkwardImu(AwkwardDoubles& d, std::size_t n) {
  nav::ImuSamples imu;
  double t = 0.1 + 1.0 / 3.0;
  for (std::size_t i = 0; i < n; ++i) {
    t += 1.0 / 2000.0;
    nav::ImuSample s;
    s.t = t;
    s.dtheta = Vec3(d.odd(), d.odd(), d.odd());
    s.dvel = Vec3(d.odd(), d.odd(), d.odd());
    s.temp_c = (i % 7 == 3) ? std::numeric_limits<double>::quiet_NaN() : 25.0 + d.odd();
    imu.push_back(s);
  }
  imu[1].dtheta.x() = -0.0;
  imu[2].dvel.y() = std::numeric_limits<double>::denorm_min();
  imu[3].dvel.z() = std::numeric_limits<double>::max();
  imu[4].dtheta.z() = -std::numeric_limits<double>::min();
  return imu;
}

// A recording of a 2000 Hz IMU at an awkward latitude and gravity (and, two-axis, outer axis
// heading) with n_imu awkward samples (awkwardImu); no table, chamber or segment rows.
inline io::Recording awkwardRecording(AwkwardDoubles& d, calib::TableKind kind, std::size_t n_imu,
                                      double height_m, const std::string& imu_serial) {
  io::Recording rec;
  rec.latitude_deg = 55.7558 + d.odd() * 1e-3;
  rec.height_m = height_m;
  rec.gravity_mps2 = 9.8154321987654321;
  rec.imu_serial = imu_serial;
  rec.imu_rate_hz = 2000.0;
  rec.table_kind = kind;
  if (kind == calib::TableKind::kTwoAxis) rec.outer_axis_heading_deg = 90.0 + d.odd();
  rec.imu = awkwardImu(d, n_imu);
  return rec;
}

}  // namespace imubench::daemon::testing
