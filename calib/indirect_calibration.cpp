#include "calib/indirect_calibration.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "calib/indirect_params.h"
#include "calib/indirect_preintegration.h"
#include "calib/indirect_run_cost.h"
#include "calib/indirect_static_accel_cost.h"
#include "calib/indirect_static_gyro_cost.h"
#include "calib/static_detection.h"

namespace imubench::calib {

namespace indirect {

std::string parameterName(int global_index) {
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  if (global_index >= kTableOffset) {
    switch (global_index - kTableOffset) {
      case kTiltX:
        return "table.base_tilt.x";
      case kTiltY:
        return "table.base_tilt.y";
      case kNonorthInnerY:
        return "table.nonorthogonality.inner_y";
      case kNonorthMiddleX:
        return "table.nonorthogonality.middle_x";
      case kNonorthMiddleY:
        return "table.nonorthogonality.middle_y";
      default:
        return "table.?";
    }
  }
  const std::string triad = global_index >= kGyroOffset ? "gyro." : "accel.";
  const int i = global_index % kTriadSize;
  if (i < kBias) return triad + "scale." + kAxis[i - kScale];
  if (i < kMis) return triad + "bias." + kAxis[i - kBias];
  return triad + "misalignment." + model::kMisEntries[static_cast<std::size_t>(i - kMis)].name;
}

}  // namespace indirect

namespace {

using namespace indirect;

// A static hold reduced to means.
struct Hold {
  int leg = 0;
  const Segment* segment = nullptr;
  TableAngles angles;  // mean encoder angles over the hold
  Vec3 accel_mean = Vec3::Zero();
  Vec3 gyro_mean = Vec3::Zero();
  Vec3 accel_sigma = Vec3::Zero();  // of the mean
  Vec3 gyro_sigma = Vec3::Zero();   // of the mean
  double gyro_noise = 0.0;          // per-sample rate noise, rad/s (largest axis)
};

// A rotation run between two holds.
struct Run {
  std::span<const nav::ImuSample> imu;  // the run's recording
  const Segment* segment = nullptr;
  std::size_t first = 0;  // sample indices [first, last)
  std::size_t last = 0;
  double t_start = 0.0;
  const Hold* before = nullptr;
  const Hold* after = nullptr;
};

// Index of the first sample whose interval (t_{k-1}, t_k] starts at or after t.
std::size_t firstSampleStartingAt(std::span<const nav::ImuSample> imu, double t) {
  // interval start of sample k is imu[k-1].t; for k = 0 it is imu[0].t - (imu[1].t - imu[0].t).
  auto it = std::lower_bound(imu.begin(), imu.end(), t,
                             [](const nav::ImuSample& s, double v) { return s.t < v; });
  // it: first sample with s.t >= t, i.e. sample it+1 starts at or after t.
  std::size_t k = static_cast<std::size_t>(it - imu.begin()) + 1;
  if (it == imu.begin() && imu.size() > 1 && imu[0].t - (imu[1].t - imu[0].t) >= t) k = 0;
  return std::min(k, imu.size());
}

// One past the last sample whose interval ends at or before t.
std::size_t endSampleEndingAt(std::span<const nav::ImuSample> imu, double t) {
  auto it = std::upper_bound(imu.begin(), imu.end(), t,
                             [](double v, const nav::ImuSample& s) { return v < s.t; });
  return static_cast<std::size_t>(it - imu.begin());
}

double intervalStart(std::span<const nav::ImuSample> imu, std::size_t k) {
  if (k > 0) return imu[k - 1].t;
  return imu.size() > 1 ? imu[0].t - (imu[1].t - imu[0].t) : imu[0].t;
}

TableAngles holdAngles(std::span<const TableSample> table, double t0, double t1) {
  TableAngles sum;
  int n = 0;
  auto it = std::lower_bound(table.begin(), table.end(), t0,
                             [](const TableSample& s, double v) { return s.t < v; });
  for (; it != table.end() && it->t <= t1; ++it, ++n) {
    sum.outer += it->angles.outer;
    sum.middle += it->angles.middle;
    sum.inner += it->angles.inner;
  }
  if (n > 0) return {sum.outer / n, sum.middle / n, sum.inner / n};
  // No sample inside: the nearest one.
  const double tm = 0.5 * (t0 + t1);
  auto jt = std::lower_bound(table.begin(), table.end(), tm,
                             [](const TableSample& s, double v) { return s.t < v; });
  if (jt == table.end()) --jt;
  if (jt != table.begin() && std::abs((jt - 1)->t - tm) < std::abs(jt->t - tm)) --jt;
  return jt->angles;
}

// Dense Jacobian of the problem w.r.t. [accel, gyro, table] (ambient, all free).
Eigen::MatrixXd denseJacobian(ceres::Problem& problem, double* accel, double* gyro, double* table) {
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = {accel, gyro, table};
  ceres::CRSMatrix crs;
  problem.Evaluate(eo, nullptr, nullptr, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[static_cast<std::size_t>(r)];
         k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k) {
      J(r, crs.cols[static_cast<std::size_t>(k)]) += crs.values[static_cast<std::size_t>(k)];
    }
  }
  return J;
}

WeakDirection weakDirection(const Eigen::VectorXd& v, const std::vector<int>& index,
                            double relative) {
  WeakDirection w;
  w.relative_eigenvalue = relative;
  std::vector<std::pair<std::string, double>> comps;
  for (int i = 0; i < v.size(); ++i) {
    if (std::abs(v[i]) >= 0.1)
      comps.emplace_back(parameterName(index[static_cast<std::size_t>(i)]), v[i]);
  }
  std::sort(comps.begin(), comps.end(),
            [](const auto& a, const auto& b) { return std::abs(a.second) > std::abs(b.second); });
  // Sign convention: largest component positive.
  if (!comps.empty() && comps.front().second < 0) {
    for (auto& c : comps) c.second = -c.second;
  }
  w.components = std::move(comps);
  return w;
}

double typicalMagnitude(int g, const IndirectOptions& o) {
  if (g >= kTableOffset) {
    return g - kTableOffset < kNonorthInnerY ? o.typical_base_tilt : o.typical_nonorthogonality;
  }
  const int i = g % kTriadSize;
  if (i < kBias) return o.typical_scale;
  if (i < kMis) return g >= kGyroOffset ? o.typical_gyro_bias : o.typical_accel_bias;
  return o.typical_misalignment;
}

// Information analysis on J scaled by the typical magnitudes: fixes directions the data
// cannot see (greedy, dominant parameter first) and reports the conditioning of what
// remains, naming the weakest directions. `free` marks estimated parameters (in/out).
Conditioning analyseInformation(const Eigen::MatrixXd& J, std::vector<bool>* free,
                                const IndirectOptions& opt) {
  Conditioning c;
  const int n = static_cast<int>(J.cols());
  const double lambda_min_ok =
      1.0 / (opt.unobservable_sigma_typical * opt.unobservable_sigma_typical);
  for (int pass = 0; pass <= n; ++pass) {
    std::vector<int> index;
    for (int i = 0; i < n; ++i) {
      if ((*free)[static_cast<std::size_t>(i)]) index.push_back(i);
    }
    const int m = static_cast<int>(index.size());
    if (m == 0) return c;
    Eigen::MatrixXd Js(J.rows(), m);
    for (int i = 0; i < m; ++i) {
      const int g = index[static_cast<std::size_t>(i)];
      Js.col(i) = J.col(g) * typicalMagnitude(g, opt);
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Js.transpose() * Js);
    const Eigen::VectorXd& ev = es.eigenvalues();  // ascending
    const double largest = std::max(ev[m - 1], 1e-300);
    auto direction = [&](int k) {
      WeakDirection w = weakDirection(es.eigenvectors().col(k), index, ev[k] / largest);
      w.sigma_typical = 1.0 / std::sqrt(std::max(ev[k], 1e-300));
      return w;
    };
    if (ev[0] < lambda_min_ok) {
      int dominant = 0;
      es.eigenvectors().col(0).cwiseAbs().maxCoeff(&dominant);
      const int g = index[static_cast<std::size_t>(dominant)];
      (*free)[static_cast<std::size_t>(g)] = false;
      c.fixed_unobservable.push_back(parameterName(g));
      c.weak.push_back(direction(0));
      continue;
    }
    c.condition_number = largest / ev[0];
    c.bad = c.condition_number > opt.bad_condition_number;
    for (int k = 0; k < std::min(3, m); ++k) c.weak.push_back(direction(k));
    return c;
  }
  return c;
}

}  // namespace

bool IndirectOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(static_margin_s >= 0.0)) return fail("static_margin_s must be >= 0");
  if (!(min_static_s > 0.0)) return fail("min_static_s must be > 0");
  if (!(run_pad_s >= 0.0)) return fail("run_pad_s must be >= 0");
  if (!(adjacency_tolerance_s >= 0.0)) return fail("adjacency_tolerance_s must be >= 0");
  if (max_outer_iterations < 1) return fail("max_outer_iterations must be >= 1");
  if (!(outer_tolerance_sigma > 0.0)) return fail("outer_tolerance_sigma must be > 0");
  if (!(min_accel_noise > 0.0) || !(min_gyro_noise > 0.0)) return fail("noise floors must be > 0");
  if (!(typical_scale > 0.0) || !(typical_misalignment > 0.0) || !(typical_accel_bias > 0.0) ||
      !(typical_gyro_bias > 0.0) || !(typical_base_tilt > 0.0) ||
      !(typical_nonorthogonality > 0.0)) {
    return fail("typical magnitudes must be > 0");
  }
  if (!(unobservable_sigma_typical > 0.0)) return fail("unobservable_sigma_typical must be > 0");
  if (!(bad_condition_number > 1.0)) return fail("bad_condition_number must be > 1");
  return checks.IsValid(why);
}

CalibrationResult calibrateIndirect(const IndirectInput& in, const IndirectOptions& opt) {
  CalibrationResult result;
  std::string why;
  if (!opt.IsValid(&why)) {
    result.error = "invalid options: " + why;
    return result;
  }
  std::vector<IndirectLeg> legs{{in.imu, in.table, in.segments}};
  legs.insert(legs.end(), in.extra_legs.begin(), in.extra_legs.end());
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::string where = legs.size() > 1 ? "recording " + std::to_string(l + 1) + ": " : "";
    if (legs[l].imu.size() < 2) {
      result.error = where + "fewer than 2 IMU samples";
      return result;
    }
    if (legs[l].table.empty()) {
      result.error = where + "no table samples";
      return result;
    }
    const RecordingCheck check =
        checkIncrements(legs[l].imu, opt.checks,
                        legs.size() > 1 ? "recording " + std::to_string(l + 1) : "recording");
    if (!check.ok()) {
      result.error = check.reason;
      return result;
    }
  }
  const double gravity = nav::siteGravity(in.site);
  const Vec3 w_ie_L = nav::earthRateL(in.site.latitude_rad);
  char buf[256];

  // ---- Holds: means and noise -------------------------------------------------------------
  std::vector<Hold> holds;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::span<const nav::ImuSample> imu = legs[l].imu;
    for (const Segment& seg : legs[l].segments) {
      if (seg.kind != SegmentKind::kStatic || !seg.recording) continue;
      const double t0 = seg.t0 + opt.static_margin_s;
      const double t1 = seg.t1 - opt.static_margin_s;
      if (t1 - t0 < opt.min_static_s) {
        std::snprintf(buf, sizeof(buf), "hold '%s' (%.1f-%.1f s): shorter than %.1f s, skipped",
                      seg.label.c_str(), seg.t0, seg.t1,
                      opt.min_static_s + 2 * opt.static_margin_s);
        result.warnings.emplace_back(buf);
        continue;
      }
      const std::size_t a = firstSampleStartingAt(imu, t0);
      const std::size_t b = endSampleEndingAt(imu, t1);
      if (b <= a + 2) {
        std::snprintf(buf, sizeof(buf), "hold '%s' (%.1f-%.1f s): no IMU samples, skipped",
                      seg.label.c_str(), seg.t0, seg.t1);
        result.warnings.emplace_back(buf);
        continue;
      }
      Hold h;
      h.leg = static_cast<int>(l);
      h.segment = &seg;
      Vec3 sum_a = Vec3::Zero(), sum_g = Vec3::Zero();
      double T = 0.0;
      for (std::size_t k = a; k < b; ++k) {
        sum_a += imu[k].dvel;
        sum_g += imu[k].dtheta;
      }
      T = imu[b - 1].t - intervalStart(imu, a);
      h.accel_mean = sum_a / T;
      h.gyro_mean = sum_g / T;
      Vec3 var_a = Vec3::Zero(), var_g = Vec3::Zero();
      for (std::size_t k = a; k < b; ++k) {
        const double dt = imu[k].t - intervalStart(imu, k);
        var_a += (imu[k].dvel / dt - h.accel_mean).cwiseAbs2();
        var_g += (imu[k].dtheta / dt - h.gyro_mean).cwiseAbs2();
      }
      const double n = static_cast<double>(b - a);
      for (int i = 0; i < 3; ++i) {
        const double sa = std::max(std::sqrt(var_a[i] / (n - 1)), opt.min_accel_noise);
        const double sg = std::max(std::sqrt(var_g[i] / (n - 1)), opt.min_gyro_noise);
        h.accel_sigma[i] = sa / std::sqrt(n);
        h.gyro_sigma[i] = sg / std::sqrt(n);
        h.gyro_noise = std::max(h.gyro_noise, sg);
      }
      h.angles = holdAngles(legs[l].table, t0, t1);
      holds.push_back(h);
    }
  }

  if (holds.empty()) {
    result.error = "no usable static hold in the recording (need holds of at least " +
                   std::to_string(opt.min_static_s + 2 * opt.static_margin_s) + " s)";
    return result;
  }
  std::vector<double> noises;
  for (const Hold& h : holds) noises.push_back(h.gyro_noise);
  std::nth_element(noises.begin(), noises.begin() + static_cast<long>(noises.size() / 2),
                   noises.end());
  const double gyro_noise = noises[noises.size() / 2];

  // ---- Runs: rotations between two usable holds -------------------------------------------
  std::vector<Run> runs;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::span<const nav::ImuSample> imu = legs[l].imu;
    for (const Segment& seg : legs[l].segments) {
      if (seg.kind != SegmentKind::kRotate || !seg.recording) continue;
      const Hold* before = nullptr;
      const Hold* after = nullptr;
      for (const Hold& h : holds) {
        if (h.leg != static_cast<int>(l)) continue;
        if (std::abs(h.segment->t1 - seg.t0) <= opt.adjacency_tolerance_s) before = &h;
        if (std::abs(h.segment->t0 - seg.t1) <= opt.adjacency_tolerance_s) after = &h;
      }
      if (!before || !after) {
        std::snprintf(buf, sizeof(buf), "run '%s' (%.1f-%.1f s): no usable hold %s it, skipped",
                      seg.label.c_str(), seg.t0, seg.t1, before ? "after" : "before");
        result.warnings.emplace_back(buf);
        continue;
      }
      const double pad_a =
          std::min(opt.run_pad_s, 0.5 * (before->segment->t1 - before->segment->t0));
      const double pad_b = std::min(opt.run_pad_s, 0.5 * (after->segment->t1 - after->segment->t0));
      Run r;
      r.segment = &seg;
      r.first = firstSampleStartingAt(imu, seg.t0 - pad_a);
      r.last = endSampleEndingAt(imu, seg.t1 + pad_b);
      if (r.first >= r.last || r.first == 0) {
        std::snprintf(buf, sizeof(buf), "run '%s': IMU data does not cover it, skipped",
                      seg.label.c_str());
        result.warnings.emplace_back(buf);
        continue;
      }
      r.t_start = intervalStart(imu, r.first);
      r.imu = imu;
      r.before = before;
      r.after = after;
      runs.push_back(r);
    }
  }

  // ---- Parameters ----------------------------------------------------------------------------
  double accel[kTriadSize], gyro[kTriadSize], table[kTableSize];
  const SensorModel start = in.start.value_or(SensorModel{});
  const auto accel0 = start.accel.block(), gyro0 = start.gyro.block();
  std::copy(accel0.begin(), accel0.end(), accel);
  std::copy(gyro0.begin(), gyro0.end(), gyro);
  table[kTiltX] = in.start_base_tilt.x();
  table[kTiltY] = in.start_base_tilt.y();
  table[kNonorthInnerY] = in.start_nonorthogonality.inner_y;
  table[kNonorthMiddleX] = in.start_nonorthogonality.middle_x;
  table[kNonorthMiddleY] = in.start_nonorthogonality.middle_y;

  std::vector<bool> free(kParamCount, true);
  std::vector<bool> held(kParamCount, false);     // held at the start values by convention
  std::vector<bool> in_model(kParamCount, true);  // false: not part of this table's chain
  auto hold = [&](int g) {
    free[static_cast<std::size_t>(g)] = false;
    held[static_cast<std::size_t>(g)] = true;
  };
  if (in.geometry.kind == TableKind::kTwoAxis) {
    for (int i : {kNonorthMiddleX, kNonorthMiddleY}) {
      hold(kTableOffset + i);
      in_model[static_cast<std::size_t>(kTableOffset + i)] = false;
      table[i] = 0.0;
    }
  }
  if (!opt.estimate_base_tilt) {
    hold(kTableOffset + kTiltX);
    hold(kTableOffset + kTiltY);
  }
  if (!opt.estimate_nonorthogonality) {
    for (int i : {kNonorthInnerY, kNonorthMiddleX, kNonorthMiddleY}) hold(kTableOffset + i);
  }
  if (opt.gyro_reference == GyroReference::kStartValues) {
    if (in.start) {
      for (int i = 0; i < 6; ++i) hold(kGyroOffset + kMis + i);
    } else {
      result.warnings.emplace_back(
          "no start values: gyro misalignments estimated from the runs (not from the direct "
          "calibration)");
    }
  }
  std::vector<double> sigma(kParamCount, 0.0);
  bool analysed = false;

  for (int outer = 0; outer < opt.max_outer_iterations; ++outer) {
    ceres::Problem problem;
    problem.AddParameterBlock(accel, kTriadSize);
    problem.AddParameterBlock(gyro, kTriadSize);
    problem.AddParameterBlock(table, kTableSize);
    for (const Hold& h : holds) {
      problem.AddResidualBlock(
          StaticAccelCost::Create(h.accel_mean, in.geometry, h.angles, gravity, h.accel_sigma),
          nullptr, accel, table);
      problem.AddResidualBlock(
          StaticGyroCost::Create(h.gyro_mean, in.geometry, h.angles, w_ie_L, h.gyro_sigma), nullptr,
          gyro, table);
    }
    for (const Run& r : runs) {
      // Navigate from the start setting at the current table estimate.
      const Mat3 C_LP_start0 = platformAttitude(in.geometry, r.before->angles, table);
      const RunPreintegration pre = preintegrateRun(r.imu.subspan(r.first, r.last - r.first),
                                                    r.t_start, C_LP_start0, gyro, w_ie_L);
      const double sigma_angle = std::max(gyro_noise, opt.min_gyro_noise) * pre.duration_s /
                                 std::sqrt(std::max(pre.samples, 1));
      problem.AddResidualBlock(RunCost::Create(pre, in.geometry, r.before->angles, r.after->angles,
                                               C_LP_start0, sigma_angle),
                               nullptr, gyro, table);
    }

    if (!analysed) {
      const Eigen::MatrixXd J = denseJacobian(problem, accel, gyro, table);
      result.conditioning = analyseInformation(J, &free, opt);
      analysed = true;
    }
    auto fixedIn = [&free](int offset, int size) {
      std::vector<int> f;
      for (int i = 0; i < size; ++i) {
        if (!free[static_cast<std::size_t>(offset + i)]) f.push_back(i);
      }
      return f;
    };
    const std::vector<int> fa = fixedIn(kAccelOffset, kTriadSize);
    const std::vector<int> fg = fixedIn(kGyroOffset, kTriadSize);
    const std::vector<int> ft = fixedIn(kTableOffset, kTableSize);
    if (fa.size() == kTriadSize) {
      problem.SetParameterBlockConstant(accel);
    } else if (!fa.empty()) {
      problem.SetManifold(accel, new ceres::SubsetManifold(kTriadSize, fa));
    }
    if (fg.size() == kTriadSize) {
      problem.SetParameterBlockConstant(gyro);
    } else if (!fg.empty()) {
      problem.SetManifold(gyro, new ceres::SubsetManifold(kTriadSize, fg));
    }
    if (ft.size() == kTableSize) {
      problem.SetParameterBlockConstant(table);
    } else if (!ft.empty()) {
      problem.SetManifold(table, new ceres::SubsetManifold(kTableSize, ft));
    }

    double before_values[kParamCount];
    std::copy(accel, accel + kTriadSize, before_values + kAccelOffset);
    std::copy(gyro, gyro + kTriadSize, before_values + kGyroOffset);
    std::copy(table, table + kTableSize, before_values + kTableOffset);

    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.function_tolerance = 1e-15;
    so.parameter_tolerance = 1e-15;
    so.gradient_tolerance = 1e-20;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    so.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    result.solver_report = summary.BriefReport();
    result.outer_iterations = outer + 1;
    if (!summary.IsSolutionUsable()) {
      result.error = "Ceres solve failed: " + summary.message;
      return result;
    }
    const int nres = problem.NumResiduals();
    result.rms_normalised_residual = nres > 0 ? std::sqrt(2.0 * summary.final_cost / nres) : 0.0;

    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    co.null_space_rank = -1;
    co.num_threads = 1;
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks = {
        {accel, accel}, {gyro, gyro}, {table, table}};
    if (!cov.Compute(blocks, &problem)) {
      result.error = "covariance could not be computed (rank-deficient information matrix: " +
                     result.conditioning.describe() + ")";
      return result;
    }
    double ca[kTriadSize * kTriadSize], cg[kTriadSize * kTriadSize], ct[kTableSize * kTableSize];
    cov.GetCovarianceBlock(accel, accel, ca);
    cov.GetCovarianceBlock(gyro, gyro, cg);
    cov.GetCovarianceBlock(table, table, ct);
    for (int i = 0; i < kTriadSize; ++i) {
      sigma[static_cast<std::size_t>(kAccelOffset + i)] =
          std::sqrt(std::max(ca[i * kTriadSize + i], 0.0));
      sigma[static_cast<std::size_t>(kGyroOffset + i)] =
          std::sqrt(std::max(cg[i * kTriadSize + i], 0.0));
    }
    for (int i = 0; i < kTableSize; ++i) {
      sigma[static_cast<std::size_t>(kTableOffset + i)] =
          std::sqrt(std::max(ct[i * kTableSize + i], 0.0));
    }
    double worst = 0.0;
    const double* now[3] = {accel, gyro, table};
    const int offsets[3] = {kAccelOffset, kGyroOffset, kTableOffset};
    const int sizes[3] = {kTriadSize, kTriadSize, kTableSize};
    for (int b = 0; b < 3; ++b) {
      for (int i = 0; i < sizes[b]; ++i) {
        const std::size_t g = static_cast<std::size_t>(offsets[b] + i);
        if (!free[g] || !(sigma[g] > 0.0)) continue;
        worst = std::max(worst, std::abs(now[b][i] - before_values[g]) / sigma[g]);
      }
    }
    if (worst < opt.outer_tolerance_sigma) break;
  }

  // ---- Report ------------------------------------------------------------------------------
  CoefficientReport& rep = result.coefficients;
  rep.values.sensors.accel = TriadModel::fromBlock(accel);
  rep.values.sensors.gyro = TriadModel::fromBlock(gyro);
  rep.values.table.base_tilt = Vec2(table[kTiltX], table[kTiltY]);
  rep.values.table.nonorthogonality = {table[kNonorthInnerY], table[kNonorthMiddleX],
                                       table[kNonorthMiddleY]};
  rep.values.table_kind = in.geometry.kind;
  for (int i = 0; i < kParamCount; ++i) {
    const std::string name = parameterName(i);
    const std::size_t g = static_cast<std::size_t>(i);
    if (!in_model[g]) continue;
    if (free[g]) {
      rep.setSigma(name, sigma[g]);
      continue;
    }
    // Held or unobservable: the start value stays, with its own uncertainty if known.
    const auto it = in.start_uncertainty.find(name);
    if (it != in.start_uncertainty.end()) rep.uncertainty[name] = it->second;
    if (!held[g]) rep.setUnobservable(name);
  }
  // Navigation-based calibration cannot see the mounting: it is absorbed by the misalignments.
  rep.setUnobservable("table.mounting.x");
  rep.setUnobservable("table.mounting.y");
  if (runs.empty()) result.warnings.emplace_back("no usable rotation run: statics only");
  result.ok = true;
  return result;
}

GyroReferencedTruth toGyroReferenced(const BenchTruth& truth, const TableGeometry& geometry) {
  GyroReferencedTruth out;
  const TableErrors& e = truth.table;
  const Vec3 mu(e.mounting.x(), e.mounting.y(), 0.0);
  const Mat3 E = Rz(e.encoder_zero.inner) * quatFromRotationVector(mu).toRotationMatrix();
  auto mapTriad = [&E](const TriadModel& t) {
    const Mat3 M = t.M() * E.transpose();
    TriadModel o;
    const Vec3 d = M.diagonal();
    Mat3 Mn = d.asDiagonal().inverse() * M;
    o.scale = t.scale.cwiseProduct(d);
    o.bias = t.bias.cwiseQuotient(d);
    o.mis = misalignmentFrom(model::misalignmentsOf(Mn).data());
    return o;
  };
  out.sensors.accel = mapTriad(truth.sensors.accel);
  out.sensors.gyro = mapTriad(truth.sensors.gyro);
  out.base_tilt = e.base_tilt;
  out.nonorthogonality = e.nonorthogonality;
  // Rx(middle + m0) = Rx(m0) Rx(middle): the middle zero is a rotation about x right after
  // nu1, i.e. part of middle_x.
  if (geometry.kind == TableKind::kThreeAxis)
    out.nonorthogonality.middle_x += e.encoder_zero.middle;
  if (geometry.kind == TableKind::kTwoAxis) {
    const double h = geometry.outer_axis_heading_rad;
    out.base_tilt += e.encoder_zero.outer * Vec2(std::sin(h), std::cos(h));
  }
  return out;
}

}  // namespace imubench::calib
