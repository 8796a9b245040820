#include "calib/truth_comparison.h"

#include <algorithm>
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

namespace {

bool discrete(const std::string& name) {
  return name.ends_with(".axis") || name.ends_with(".order");
}

// Rows of the extra effects: the estimate's (judged when it carries a sigma) and the truth's
// that the estimate does not model.
void compareExtra(const CoefficientReport& estimate, const BenchTruth& expected,
                  TruthComparison* c) {
  std::vector<std::string> names;
  for (const BenchTruth* b : {&estimate.values, &expected}) {
    for (const std::string& n : flatNames(*b)) {
      if (startsWith(n, "extra.") && !discrete(n) &&
          std::find(names.begin(), names.end(), n) == names.end()) {
        names.push_back(n);
      }
    }
  }
  for (const std::string& name : names) {
    const std::optional<double> e = flatValue(estimate.values, name);
    const std::optional<double> t = flatValue(expected, name);
    const auto u = estimate.uncertainty.find(name);
    const bool estimated = e && u != estimate.uncertainty.end();
    if (!estimated && (!t || *t == 0.0)) continue;  // neither estimated nor in the truth
    ComparisonRow r;
    r.name = name;
    r.estimate = e.value_or(0.0);
    r.expected = t.value_or(0.0);
    r.error = r.estimate - r.expected;
    r.unit = "SI";
    r.error_in_unit = r.error;
    r.modelled = estimated;
    r.observable = estimated && u->second.observable && u->second.sigma.has_value();
    r.sigma = estimated ? u->second.sigma.value_or(0.0) : 0.0;
    r.limit_in_unit = kBiasLimitSigma * r.sigma;
    r.within = std::abs(r.error) <= r.limit_in_unit;
    if (r.observable) {
      ++c->judged;
      if (!r.within) ++c->outside;
    }
    if (!r.modelled) ++c->unmodelled;
    c->rows.push_back(r);
  }
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
  compareExtra(estimate, expected, &c);
  return c;
}

}  // namespace imubench::calib
