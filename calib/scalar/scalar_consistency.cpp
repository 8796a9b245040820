#include "calib/scalar/scalar_consistency.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "calib/recording_checks.h"

namespace imubench::calib {
namespace {

// The samples [begin, end) as a recording of their own (times unchanged).
RawImuData slice(const RawImuData& data, std::size_t begin, std::size_t end) {
  RawImuData out;
  out.t.assign(data.t.begin() + begin, data.t.begin() + end);
  out.accel.assign(data.accel.begin() + begin, data.accel.begin() + end);
  out.gyro.assign(data.gyro.begin() + begin, data.gyro.begin() + end);
  return out;
}

// sqrt(chi^2 / dof) of |f| - g per pose against the pose mean's white-noise sigma.
void accelNormalisedRms(const RawImuData& data, const ScalarCalibrationResult& full,
                        const ScalarCalibrationOptions& options, ScalarConsistency* out) {
  const TriadModel& accel = full.accel();
  double chi2 = 0.0;
  int poses = 0;
  for (const StaticSpan& sp : full.spans) {
    std::size_t b = sp.begin, e = sp.end;
    while (b + 2 < e && data.t[b] < sp.t0 + options.span_trim_s) ++b;
    while (e > b + 2 && data.t[e - 1] > sp.t1 - options.span_trim_s) --e;
    const double n = static_cast<double>(e - b);
    if (n < 3) continue;
    Vec3 mean = Vec3::Zero();
    for (std::size_t i = b; i < e; ++i) mean += data.accel[i];
    mean /= n;
    Vec3 var = Vec3::Zero();
    for (std::size_t i = b; i < e; ++i) var += (data.accel[i] - mean).cwiseAbs2();
    var /= n - 1.0;
    const Vec3 f = accel.input(mean);
    // |f| moves with each reading axis k by (f_k / |f|) / scale_k.
    double s2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double d = f[k] / f.norm() / accel.scale[k];
      s2 += d * d * var[k];
    }
    const double sigma = std::sqrt(s2 / n);
    if (!(sigma > 0.0)) continue;
    const double r = (f.norm() - options.gravity_mps2) / sigma;
    chi2 += r * r;
    ++poses;
  }
  int fitted = 0;
  for (const auto& [name, u] : full.report.uncertainty) {
    if (name.rfind("accel.", 0) == 0 && u.observable && u.sigma) ++fitted;
  }
  out->accel_dof = poses - fitted;
  out->accel_normalised_rms = out->accel_dof > 0 ? std::sqrt(chi2 / out->accel_dof) : 0.0;
}

// Every triad coefficient with a sigma in both halves: z of their difference.
void compareHalves(const ScalarCalibrationResult& a, const ScalarCalibrationResult& b,
                   ScalarConsistency* out) {
  const std::vector<std::string> names = flatNames(a.report.values);
  const std::vector<double> va = flatValues(a.report.values);
  const std::vector<double> vb = flatValues(b.report.values);
  double sum_z2 = 0.0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& n = names[i];
    if (n.rfind("accel.", 0) != 0 && n.rfind("gyro.", 0) != 0) continue;
    const auto ia = a.report.uncertainty.find(n);
    const auto ib = b.report.uncertainty.find(n);
    if (ia == a.report.uncertainty.end() || ib == b.report.uncertainty.end()) continue;
    if (!ia->second.observable || !ib->second.observable) continue;
    if (!ia->second.sigma || !ib->second.sigma) continue;
    const double sa = *ia->second.sigma, sb = *ib->second.sigma;
    const double s = std::hypot(sa, sb);
    if (!(s > 0.0)) continue;
    const ScalarConsistencyRow row{n, va[i], sa, vb[i], sb, (va[i] - vb[i]) / s};
    sum_z2 += row.z * row.z;
    if (std::abs(row.z) > out->max_abs_z) {
      out->max_abs_z = std::abs(row.z);
      out->worst = n;
    }
    out->rows.push_back(row);
  }
  if (!out->rows.empty()) out->rms_z = std::sqrt(sum_z2 / static_cast<double>(out->rows.size()));
}

// Median over the poses of the fewest distinct accelerometer readings on any axis.
int typicalDistinctReadings(const RawImuData& data, const std::vector<StaticSpan>& spans) {
  std::vector<int> per_pose;
  for (const StaticSpan& sp : spans) {
    double mag = 0.0;
    for (std::size_t i = sp.begin; i < sp.end; ++i) mag = std::max(mag, data.accel[i].norm());
    int fewest = std::numeric_limits<int>::max();
    for (int k = 0; k < 3; ++k) {
      std::vector<double> v;
      for (std::size_t i = sp.begin; i < sp.end; ++i) v.push_back(data.accel[i](k));
      fewest = std::min(fewest, countDistinct(std::move(v), 1e-9 * mag + 1e-300));
    }
    per_pose.push_back(fewest);
  }
  if (per_pose.empty()) return 0;
  std::sort(per_pose.begin(), per_pose.end());
  return per_pose[per_pose.size() / 2];
}

}  // namespace

ScalarConsistency scalarConsistency(const RawImuData& data, const ScalarCalibrationResult& full,
                                    const ScalarCalibrationOptions& options,
                                    bool accel_unit_is_si) {
  ScalarConsistency out;
  if (typicalDistinctReadings(data, full.spans) <= kMaxResolutionValues) {
    out.resolution_limited = true;
    out.accel_normalised_rms = std::numeric_limits<double>::quiet_NaN();
    out.halves_why =
        "noise-free data: the static poses' readings take at most " +
        std::to_string(kMaxResolutionValues) +
        " distinct values on some axis, so there is no noise to judge residuals or sigmas by";
    return out;
  }
  accelNormalisedRms(data, full, options, &out);
  if (full.spans.size() < 4) {
    out.halves_why = "fewer than 4 static poses: nothing to split";
    return out;
  }
  // The cut: the middle of the static pose whose middle is nearest the recording's middle.
  const double t_mid = 0.5 * (data.t.front() + data.t.back());
  const StaticSpan* cut = &full.spans[1];
  for (std::size_t k = 1; k + 1 < full.spans.size(); ++k) {
    const StaticSpan& sp = full.spans[k];
    if (std::abs(0.5 * (sp.t0 + sp.t1) - t_mid) < std::abs(0.5 * (cut->t0 + cut->t1) - t_mid))
      cut = &sp;
  }
  const std::size_t at = (cut->begin + cut->end) / 2;
  out.split_t = data.t[at];
  ScalarCalibrationOptions second_options = options;
  second_options.min_initial_static_s =
      std::min(options.min_initial_static_s, 0.5 * (cut->t1 - cut->t0) - options.span_trim_s);
  const ScalarCalibrationResult first =
      scalarCalibrate(slice(data, 0, at), options, accel_unit_is_si);
  const ScalarCalibrationResult second =
      scalarCalibrate(slice(data, at, data.size()), second_options, accel_unit_is_si);
  if (!first.status.ok || !second.status.ok) {
    out.halves_why = !first.status.ok ? "first half: " + first.status.message
                                      : "second half: " + second.status.message;
    return out;
  }
  out.first_poses = first.spans.size();
  out.second_poses = second.spans.size();
  compareHalves(first, second, &out);
  out.halves_ok = !out.rows.empty();
  if (!out.halves_ok) out.halves_why = "no coefficient has a sigma in both halves";
  return out;
}

std::string describe(const ScalarConsistency& c) {
  std::ostringstream o;
  o.precision(3);
  if (c.resolution_limited) {
    o << "accel normalised residual RMS: not meaningful (" << c.halves_why << ")\n";
    return o.str();
  }
  o << "accel normalised residual RMS (|f| - g per pose against its white-noise sigma): "
    << c.accel_normalised_rms << " over " << c.accel_dof << " degrees of freedom\n";
  if (!c.halves_ok) {
    o << "half against half: not compared (" << c.halves_why << ")\n";
    return o.str();
  }
  o << "half against half (cut at t = " << c.split_t << " s; " << c.first_poses << " and "
    << c.second_poses << " poses): " << c.rows.size() << " coefficients, RMS z = " << c.rms_z
    << ", largest |z| = " << c.max_abs_z << " (" << c.worst << ")\n";
  return o.str();
}

SigmaCheck sigmaCheckFromHalves(const ScalarConsistency& c, const CoefficientReport& full,
                                const SigmaCheckOptions& options) {
  SigmaCheck out;
  if (!c.halves_ok || c.rows.empty()) {
    out.why_not = c.halves_why.empty() ? "the halves were not compared" : c.halves_why;
    return out;
  }
  constexpr double kMedianAbsZ = 0.6745;  // median of |z| for z ~ N(0, 1)
  std::map<std::string, double> printed, resampled;
  for (const ScalarConsistencyRow& r : c.rows) {
    const auto it = full.uncertainty.find(r.name);
    if (it == full.uncertainty.end() || !it->second.sigma || !it->second.observable) continue;
    printed[r.name] = *it->second.sigma;
    resampled[r.name] = *it->second.sigma * std::abs(r.z) / kMedianAbsZ;
  }
  out = compareSigmas(printed, resampled, options);
  out.resamples = 2;
  out.method = "half against half, |z| / 0.674 per coefficient";
  return out;
}

}  // namespace imubench::calib
