#include "calib/indirect/bench_calibration.h"

#include <algorithm>
#include <cmath>
#include <string>

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

// The largest change of an estimated nonorthogonality component from `previous`, in its
// sigmas (0 when none is estimated).
double nonorthogonalityChange(const Nonorthogonality& previous, const CalibrationResult& r) {
  const Nonorthogonality& nu = r.coefficients.values.table.nonorthogonality;
  const std::pair<const char*, double> parts[3] = {
      {"table.nonorthogonality.inner_y", nu.inner_y - previous.inner_y},
      {"table.nonorthogonality.middle_x", nu.middle_x - previous.middle_x},
      {"table.nonorthogonality.middle_y", nu.middle_y - previous.middle_y}};
  double worst = 0.0;
  for (const auto& [name, change] : parts) {
    const auto it = r.coefficients.uncertainty.find(name);
    if (it == r.coefficients.uncertainty.end() || !it->second.observable || !it->second.sigma ||
        !(*it->second.sigma > 0.0)) {
      continue;
    }
    worst = std::max(worst, std::abs(change) / *it->second.sigma);
  }
  return worst;
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
  if (max_passes < 1) {
    if (why) *why = "max_passes must be >= 1";
    return false;
  }
  if (!(convergence_sigma > 0.0)) {
    if (why) *why = "convergence_sigma must be > 0";
    return false;
  }
  return direct.IsValid(why) && indirect.IsValid(why);
}

BenchCalibrationResult calibrateBench(const BenchCalibrationInput& in,
                                      const BenchCalibrationOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) {
    BenchCalibrationResult r;
    r.status = FitStatus::Failed("invalid options: " + why);
    return r;
  }
  return calibrateBenchFrom(in, calibrateDirect(in.direct, o.direct), o);
}

BenchCalibrationResult calibrateBenchFrom(const BenchCalibrationInput& in,
                                          const DirectCalibrationResult& first,
                                          const BenchCalibrationOptions& o) {
  BenchCalibrationResult r;
  std::string why;
  if (!o.IsValid(&why)) {
    r.status = FitStatus::Failed("invalid options: " + why);
    return r;
  }
  r.direct = first;
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
  // Further passes: the direct calibration against the table's axes as last estimated, the
  // refinement from it. Each pass removes about half of the nonorthogonality the direct gyro
  // misalignments still carry, so passes go on until it settles.
  DirectCalibrationOptions dk = o.direct;
  for (int pass = 2; pass <= o.max_passes; ++pass) {
    const Nonorthogonality previous = r.refined.coefficients.values.table.nonorthogonality;
    dk.known_table_errors.nonorthogonality = previous;
    r.direct_final = calibrateDirect(in.direct, dk);
    if (!r.direct_final.status.HasResult()) {
      r.status = FitStatus::Failed("direct calibration with the estimated nonorthogonality: " +
                                   r.direct_final.status.message);
      return r;
    }
    r.refined = refine(in, r.direct_final, dk.known_table_errors, o.indirect);
    r.passes = pass;
    if (!r.refined.status.HasResult()) {
      r.status = FitStatus::Failed("navigation-based refinement (pass " + std::to_string(pass) +
                                   "): " + r.refined.status.message);
      return r;
    }
    if (nonorthogonalityChange(previous, r.refined) < o.convergence_sigma) break;
  }
  r.status = r.refined.status;
  return r;
}

}  // namespace imubench::calib
