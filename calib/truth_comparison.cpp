#include "calib/truth_comparison.h"

#include <cmath>

namespace imubench::calib {

namespace {

constexpr double kUgToMps2 = 9.80665e-6;
constexpr double kMisalignmentLimitArcsec = 3.0;
constexpr double kScaleLimitPpm = 10.0;
constexpr double kBiasLimitSigma = 2.0;

bool startsWith(const std::string& s, const char* prefix) {
  return s.rfind(prefix, 0) == 0;
}

}  // namespace

TruthComparison compareWithTruth(const CoefficientReport& estimate, const BenchTruth& expected) {
  TruthComparison c;
  for (const std::string& name : flatNames(estimate.values)) {
    if (startsWith(name, "extra.") || startsWith(name, "table.mounting") ||
        startsWith(name, "table.encoder_zero")) {
      continue;
    }
    const std::optional<double> e = flatValue(estimate.values, name);
    const std::optional<double> t = flatValue(expected, name);
    if (!e || !t) continue;
    const auto u = estimate.uncertainty.find(name);
    if (u == estimate.uncertainty.end()) continue;  // not estimated by this method
    ComparisonRow r;
    r.name = name;
    r.estimate = *e;
    r.expected = *t;
    r.error = *e - *t;
    r.observable = u->second.observable;
    r.sigma = u->second.sigma.value_or(0.0);
    if (name.find(".scale.") != std::string::npos) {
      r.unit = "ppm";
      r.error_in_unit = r.error * 1e6;
      r.limit_in_unit = kScaleLimitPpm;
    } else if (name.find(".bias.") != std::string::npos) {
      const bool accel = startsWith(name, "accel.");
      const double unit = accel ? kUgToMps2 : kDegPerHourToRadPerSec;
      r.unit = accel ? "ug" : "deg/h";
      r.error_in_unit = r.error / unit;
      r.limit_in_unit = kBiasLimitSigma * r.sigma / unit;
    } else {
      r.unit = "arcsec";
      r.error_in_unit = r.error * kRadToArcsec;
      r.limit_in_unit = kMisalignmentLimitArcsec;
    }
    r.within = std::abs(r.error_in_unit) <= r.limit_in_unit;
    if (r.observable) {
      ++c.judged;
      if (!r.within) ++c.outside;
    }
    c.rows.push_back(r);
  }
  return c;
}

}  // namespace imubench::calib
