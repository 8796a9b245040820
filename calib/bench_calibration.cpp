#include "calib/bench_calibration.h"

#include <cmath>

namespace imubench::calib {

namespace {

// Nonorthogonality components estimated by the refinement, with their sigmas.
bool nonorthogonalitySignificant(const CalibrationResult& r, double n_sigma) {
  const Nonorthogonality& nu = r.coefficients.values.table.nonorthogonality;
  const std::pair<const char*, double> parts[3] = {
      {"table.nonorthogonality.inner_y", nu.inner_y},
      {"table.nonorthogonality.middle_x", nu.middle_x},
      {"table.nonorthogonality.middle_y", nu.middle_y}};
  for (const auto& [name, value] : parts) {
    const auto it = r.coefficients.uncertainty.find(name);
    if (it == r.coefficients.uncertainty.end() || !it->second.observable || !it->second.sigma) {
      continue;
    }
    if (std::abs(value) > n_sigma * *it->second.sigma) return true;
  }
  return false;
}

// The refinement from the direct result d, the table errors starting at those the direct
// calibration was given (known beforehand, or fed back from the first pass).
CalibrationResult refine(const BenchCalibrationInput& in, const DirectCalibrationResult& d,
                         const TableErrors& known, const IndirectOptions& o) {
  IndirectInput ii;
  ii.site = in.direct.site;
  ii.geometry = in.direct.geometry;
  // The first navigation recording is the main one; the direct recording joins as a leg.
  const IndirectLeg direct_leg{in.direct.imu, in.direct.table, in.direct.segments};
  const IndirectLeg& main = in.navigation.empty() ? direct_leg : in.navigation.front();
  ii.imu = main.imu;
  ii.table = main.table;
  ii.segments = main.segments;
  for (std::size_t k = 1; k < in.navigation.size(); ++k) ii.extra_legs.push_back(in.navigation[k]);
  if (!in.navigation.empty()) ii.extra_legs.push_back(direct_leg);
  ii.start = d.report.values.sensors;
  ii.start_uncertainty = d.report.uncertainty;
  ii.start_base_tilt = known.base_tilt;
  ii.start_nonorthogonality = known.nonorthogonality;
  return calibrateIndirect(ii, o);
}

}  // namespace

bool BenchCalibrationOptions::IsValid(std::string* why) const {
  if (!(nonorthogonality_significance_sigma >= 0.0)) {
    if (why) *why = "nonorthogonality_significance_sigma must be >= 0";
    return false;
  }
  return direct.IsValid(why) && indirect.IsValid(why);
}

BenchCalibrationResult calibrateBench(const BenchCalibrationInput& in,
                                      const BenchCalibrationOptions& o) {
  BenchCalibrationResult r;
  std::string why;
  if (!o.IsValid(&why)) {
    r.status = FitStatus::Failed("invalid options: " + why);
    return r;
  }
  r.direct = calibrateDirect(in.direct, o.direct);
  if (!r.direct.status.HasResult()) {
    r.status = FitStatus::Failed("direct calibration: " + r.direct.status.message);
    return r;
  }
  r.direct_final = r.direct;
  r.refined = refine(in, r.direct, o.direct.known_table_errors, o.indirect);
  r.passes = 1;
  if (!r.refined.status.HasResult()) {
    r.status = FitStatus::Failed("navigation-based refinement: " + r.refined.status.message);
    return r;
  }
  if (!nonorthogonalitySignificant(r.refined, o.nonorthogonality_significance_sigma)) {
    r.status = r.refined.status;
    return r;
  }
  // Second pass: the direct calibration against the table's real axes.
  DirectCalibrationOptions d2 = o.direct;
  d2.known_table_errors.nonorthogonality = r.refined.coefficients.values.table.nonorthogonality;
  r.direct_final = calibrateDirect(in.direct, d2);
  if (!r.direct_final.status.HasResult()) {
    r.status = FitStatus::Failed("direct calibration with the estimated nonorthogonality: " +
                                 r.direct_final.status.message);
    return r;
  }
  r.refined = refine(in, r.direct_final, d2.known_table_errors, o.indirect);
  r.passes = 2;
  if (!r.refined.status.HasResult()) {
    r.status =
        FitStatus::Failed("navigation-based refinement (second pass): " + r.refined.status.message);
    return r;
  }
  r.status = r.refined.status;
  return r;
}

}  // namespace imubench::calib
