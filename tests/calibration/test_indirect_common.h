// Shared helpers of the navigation-based calibration tests: random navigation-grade benches,
// simulate + calibrate, and the accuracy checks of issue 3 item 2.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "calib/indirect/indirect_calibration.h"
#include "calib/simulator.h"

namespace imubench::calib::testing {

inline constexpr double kUg = 9.80665e-6;

struct Bench {
  BenchTruth truth;
  NoiseModel noise;
};

// Navigation-grade sensors (gyro ARW 0.002 deg/sqrt(h), bias 0.01 deg/h; accel 20 ug/sqrt(Hz),
// bias 50 ug) and table errors of 10-60 arcsec with random signs.
// with_nonorthogonality: the table's axes are also nonorthogonal (10-60 arcsec each component,
// and a three-axis middle encoder zero); drawn after everything else, so the rest of the bench
// is the same as without.
inline Bench randomBench(std::uint64_t seed, TableKind kind, bool with_nonorthogonality = false) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> mag(10.0, 60.0);
  auto sgn = [&] { return u(rng) < 0 ? -1.0 : 1.0; };
  auto tableErr = [&] { return sgn() * mag(rng) * kArcsecToRad; };
  Bench b;
  for (TriadModel* t : {&b.truth.sensors.accel, &b.truth.sensors.gyro}) {
    for (int i = 0; i < 3; ++i) t->scale[i] = 1.0 + 300e-6 * u(rng);
    t->mis = {100 * kArcsecToRad * u(rng), 100 * kArcsecToRad * u(rng),
              100 * kArcsecToRad * u(rng), 100 * kArcsecToRad * u(rng),
              100 * kArcsecToRad * u(rng), 100 * kArcsecToRad * u(rng)};
  }
  for (int i = 0; i < 3; ++i) {
    b.truth.sensors.accel.bias[i] = sgn() * 50.0 * kUg;
    b.truth.sensors.gyro.bias[i] = sgn() * 0.01 * kDegPerHourToRadPerSec;
  }
  b.truth.table_kind = kind;
  b.truth.table.base_tilt = Vec2(tableErr(), tableErr());
  b.truth.table.mounting = Vec2(tableErr(), tableErr());
  if (kind == TableKind::kTwoAxis) {
    b.truth.table.encoder_zero.outer = tableErr();
    b.truth.table.encoder_zero.inner = tableErr();
  } else {
    b.truth.table.encoder_zero.inner = tableErr();
  }
  if (with_nonorthogonality) {
    b.truth.table.nonorthogonality.inner_y = tableErr();
    if (kind == TableKind::kThreeAxis) {
      b.truth.table.nonorthogonality.middle_x = tableErr();
      b.truth.table.nonorthogonality.middle_y = tableErr();
      b.truth.table.encoder_zero.middle = tableErr();
    }
  }
  b.noise.gyro.white = 0.002 * kDegToRad / 60.0;
  b.noise.accel.white = 20.0 * kUg;
  return b;
}

struct Outcome {
  CalibrationResult result;
  GyroReferencedTruth expected;
};

inline Outcome runBench(const Motion& motion, const Bench& bench, std::uint64_t seed,
                        double rate_hz, const std::optional<SensorModel>& start = std::nullopt,
                        const std::map<std::string, Uncertainty>& start_uncertainty = {}) {
  SimulatorInput si;
  si.world.site.latitude_rad = 58.0 * kDegToRad;
  si.world.site.height_m = 100.0;
  si.world.truth = bench.truth;
  si.world.noise = bench.noise;
  si.motion = motion;
  SimOptions so;
  so.imu_rate_hz = rate_hz;
  so.table_rate_hz = 10.0;
  so.seed = seed;
  const Simulation sim = simulate(si, so);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;

  IndirectInput in;
  in.site = si.world.site;
  in.geometry.kind = motion.kind;
  in.imu = sim.imu;
  in.table = sim.table;
  in.segments = sim.segments;
  in.start = start;
  in.start_uncertainty = start_uncertainty;
  Outcome o;
  o.result = calibrateIndirect(in, IndirectOptions{});
  o.expected = toGyroReferenced(bench.truth, in.geometry);
  return o;
}

inline double flat(const CoefficientReport& r, const std::string& name) {
  return flatValue(r.values, name).value();
}

// Biases are random: with honest sigmas each is within 2 sigma of truth 95.4 % of the time, so
// a bench with 6 biases has one outside 2 sigma in about a quarter of the draws (measured over
// 40 benches per plan: 4.6-5 % of biases outside 2 sigma, mean z^2 0.95-1.0). A single bench
// is held to 4 sigma (a gross-error bound: 6e-5 per bias); coverage of 2 sigma and the sigmas'
// honesty are checked over many benches (IndirectLibraryPlans/BiasCoverage.*).
inline constexpr double kBiasSigmaBound = 4.0;

// (estimate - truth) / sigma of the six biases.
inline std::vector<double> biasZScores(const Outcome& o) {
  std::vector<double> z;
  if (!o.result.status.HasResult()) return z;
  BenchTruth truth;
  truth.sensors = o.expected.sensors;
  const CoefficientReport& r = o.result.coefficients;
  for (const char* triad : {"accel", "gyro"}) {
    for (const char* ax : {"x", "y", "z"}) {
      const std::string b = std::string(triad) + ".bias." + ax;
      const auto u = r.uncertainty.find(b);
      if (u == r.uncertainty.end() || !u->second.sigma || !(*u->second.sigma > 0.0)) continue;
      z.push_back((flat(r, b) - *flatValue(truth, b)) / *u->second.sigma);
    }
  }
  return z;
}

// allow_fixed: parameters the plan cannot see may be held at the start values (then they must
// still meet the targets: the start is the direct calibration).
inline void expectAccurate(const Outcome& o, bool allow_fixed = false) {
  ASSERT_TRUE(o.result.status.HasResult()) << o.result.status.message;
  const CoefficientReport& r = o.result.coefficients;
  BenchTruth truth;
  truth.sensors = o.expected.sensors;
  truth.table.base_tilt = o.expected.base_tilt;
  EXPECT_FALSE(o.result.conditioning.bad) << o.result.conditioning.describe();
  if (!allow_fixed) {
    EXPECT_TRUE(o.result.conditioning.fixed_unobservable.empty())
        << o.result.conditioning.describe();
  }
  for (const char* triad : {"accel", "gyro"}) {
    for (const char* ax : {"x", "y", "z"}) {
      const std::string s = std::string(triad) + ".scale." + ax;
      EXPECT_NEAR(flat(r, s), *flatValue(truth, s), 10e-6) << s;
      const std::string b = std::string(triad) + ".bias." + ax;
      ASSERT_TRUE(r.uncertainty.count(b) && r.uncertainty.at(b).sigma) << b;
      const double sigma = *r.uncertainty.at(b).sigma;
      // One bench: within kBiasSigmaBound sigma; the "within 2 sigma" target is a coverage
      // statement checked over many benches (biasZScores, IndirectLibraryPlans.*Coverage).
      EXPECT_NEAR(flat(r, b), *flatValue(truth, b), kBiasSigmaBound * sigma)
          << b << " sigma " << sigma;
    }
    for (const char* m : {"xy", "xz", "yx", "yz", "zx", "zy"}) {
      const std::string n = std::string(triad) + ".misalignment." + m;
      EXPECT_NEAR(flat(r, n) * kRadToArcsec, *flatValue(truth, n) * kRadToArcsec, 3.0) << n;
    }
  }
  for (const char* ax : {"x", "y"}) {
    const std::string n = std::string("table.base_tilt.") + ax;
    EXPECT_NEAR(flat(r, n) * kRadToArcsec, *flatValue(truth, n) * kRadToArcsec, 3.0) << n;
  }
  // The table's axis nonorthogonality, where this table's chain has it.
  truth.table.nonorthogonality = o.expected.nonorthogonality;
  truth.table_kind = r.values.table_kind;
  for (const char* c : {"inner_y", "middle_x", "middle_y"}) {
    const std::string n = std::string("table.nonorthogonality.") + c;
    const std::optional<double> expected = flatValue(truth, n);
    if (!expected) continue;
    EXPECT_NEAR(flat(r, n) * kRadToArcsec, *expected * kRadToArcsec, 3.0) << n;
  }
  EXPECT_FALSE(r.uncertainty.at("table.mounting.x").observable);
  EXPECT_LT(o.result.rms_normalised_residual, 3.0);
}

}  // namespace imubench::calib::testing
