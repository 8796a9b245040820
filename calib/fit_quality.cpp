#include "calib/fit_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace imubench::calib {

bool FitQualityOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(max_normalised_rms > 0.0)) return fail("max_normalised_rms must be > 0");
  if (!(max_scale_deviation > 0.0)) return fail("max_scale_deviation must be > 0");
  if (!(max_misalignment_rad > 0.0)) return fail("max_misalignment_rad must be > 0");
  if (!(max_scale_sigma > 0.0) || !(max_misalignment_sigma > 0.0))
    return fail("max_scale_sigma and max_misalignment_sigma must be > 0");
  return true;
}

FitQualityOptions FitQualityOptions::acceptingMisfit(double max_rms) const {
  FitQualityOptions o = *this;
  const double ratio = std::max(1.0, max_rms / max_normalised_rms);
  o.max_normalised_rms = std::max(max_rms, max_normalised_rms);
  o.max_scale_sigma *= ratio;
  o.max_misalignment_sigma *= ratio;
  return o;
}

void judgeCoefficients(const CoefficientReport& report, const FitQualityOptions& o,
                       std::vector<std::string>* reasons) {
  for (const std::string& name : flatNames(report.values)) {
    if (name.rfind("accel.", 0) != 0 && name.rfind("gyro.", 0) != 0) continue;
    const double v = flatValue(report.values, name).value_or(0.0);
    const auto it = report.uncertainty.find(name);
    if (it != report.uncertainty.end() && !it->second.observable) {
      reasons->push_back(name + " is not determined by the data (held at its start value)");
    } else if (it == report.uncertainty.end() || !it->second.sigma) {
      reasons->push_back(name + " was not estimated (no uncertainty)");
    }
    const bool scale = name.find(".scale.") != std::string::npos;
    const bool mis = name.find(".misalignment.") != std::string::npos;
    char buf[200];
    const double sigma =
        (it != report.uncertainty.end() && it->second.sigma) ? *it->second.sigma : 0.0;
    if ((scale && sigma > o.max_scale_sigma) || (mis && sigma > o.max_misalignment_sigma)) {
      std::snprintf(buf, sizeof(buf),
                    "%s is not determined by the data (sigma %.3g): the plan does not turn or "
                    "point that axis as needed",
                    name.c_str(), sigma);
      reasons->push_back(buf);
    }
    if ((scale && !(std::abs(v - 1.0) <= o.max_scale_deviation)) ||
        (mis && !(std::abs(v) <= o.max_misalignment_rad))) {
      std::snprintf(buf, sizeof(buf),
                    "%s = %.6g is implausible: the readings do not follow the table's motion "
                    "(columns swapped, a sign flipped, wrong units?)",
                    name.c_str(), v);
      reasons->push_back(buf);
    }
  }
}

FitStatus FitStatus::Failed(std::string why) {
  FitStatus s;
  s.ok = false;
  s.message = std::move(why);
  s.code = FitStatusCode::kFailed;
  return s;
}

FitStatus fitStatusFrom(std::vector<std::string> reasons,
                        std::vector<std::string> largest_residuals) {
  FitStatus s;
  s.largest_residuals = std::move(largest_residuals);
  if (reasons.empty()) return s;
  s.code = FitStatusCode::kUnusable;
  s.ok = false;
  s.reasons = std::move(reasons);
  s.message = "result unusable: " + s.reasons.front();
  if (s.reasons.size() > 1) {
    s.message += " (and " + std::to_string(s.reasons.size() - 1) + " more finding" +
                 (s.reasons.size() > 2 ? "s" : "") + ")";
  }
  return s;
}

}  // namespace imubench::calib
