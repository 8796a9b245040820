#include "calib/truth_comparison.h"

#include <cmath>

namespace imubench::calib {

namespace {

constexpr double kMisalignmentLimitArcsec = 3.0;
constexpr double kScaleLimitPpm = 10.0;
constexpr double kBiasLimitSigma = 2.0;

bool startsWith(const std::string& s, const char* prefix) {
  return s.rfind(prefix, 0) == 0;
}

}  // namespace

DisplayUnit displayUnit(const std::string& n) {
  if (n.find(".scale.") != std::string::npos) return {1e-6, "ppm"};
  if (startsWith(n, "accel.bias")) return {kMicroGToMps2, "ug"};
  if (startsWith(n, "gyro.bias")) return {kDegPerHourToRadPerSec, "deg/h"};
  return {kArcsecToRad, "arcsec"};
}

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
    const DisplayUnit unit = displayUnit(name);
    r.unit = unit.label;
    r.error_in_unit = r.error / unit.si_per_unit;
    if (name.find(".scale.") != std::string::npos) {
      r.limit_in_unit = kScaleLimitPpm;
    } else if (name.find(".bias.") != std::string::npos) {
      r.limit_in_unit = kBiasLimitSigma * r.sigma / unit.si_per_unit;
    } else {
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
