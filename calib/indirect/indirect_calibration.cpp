#include "calib/indirect/indirect_calibration.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <deque>
#include <map>
#include <vector>

#include "calib/indirect/indirect_params.h"
#include "calib/indirect/indirect_preintegration.h"
#include "calib/indirect/indirect_run_cost.h"
#include "calib/indirect/indirect_static_accel_cost.h"
#include "calib/indirect/indirect_static_gyro_cost.h"
#include "calib/option_check.h"
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
  if (!(static_margin_s >= 0.0)) return invalidOption(why, "static_margin_s must be >= 0");
  if (!(min_static_s > 0.0)) return invalidOption(why, "min_static_s must be > 0");
  if (!(run_pad_s >= 0.0)) return invalidOption(why, "run_pad_s must be >= 0");
  if (!(adjacency_tolerance_s >= 0.0))
    return invalidOption(why, "adjacency_tolerance_s must be >= 0");
  if (max_outer_iterations < 1) return invalidOption(why, "max_outer_iterations must be >= 1");
  if (!(outer_tolerance_sigma > 0.0))
    return invalidOption(why, "outer_tolerance_sigma must be > 0");
  if (solver.max_iterations < 1 || !(solver.function_tolerance > 0.0) ||
      !(solver.parameter_tolerance > 0.0) || !(solver.gradient_tolerance > 0.0))
    return invalidOption(why, "solver: max_iterations >= 1 and tolerances > 0");
  if (!(min_accel_noise > 0.0) || !(min_gyro_noise > 0.0))
    return invalidOption(why, "noise floors must be > 0");
  if (!(typical_scale > 0.0) || !(typical_misalignment > 0.0) || !(typical_accel_bias > 0.0) ||
      !(typical_gyro_bias > 0.0) || !(typical_base_tilt > 0.0) ||
      !(typical_nonorthogonality > 0.0)) {
    return invalidOption(why, "typical magnitudes must be > 0");
  }
  if (!(unobservable_sigma_typical > 0.0))
    return invalidOption(why, "unobservable_sigma_typical must be > 0");
  if (!(bad_condition_number > 1.0)) return invalidOption(why, "bad_condition_number must be > 1");
  if (!(min_accel_mean_sigma > 0.0) || !(min_gyro_mean_sigma > 0.0) ||
      !(min_run_angle_sigma > 0.0)) {
    if (why) *why = "the sigma floors must be > 0";
    return false;
  }
  if (!(anchor_window_s > 0.0)) return invalidOption(why, "anchor_window_s must be > 0");
  if (!segment_check.IsValid(why) || !quality.IsValid(why) || !sigma_check.IsValid(why))
    return false;
  return checks.IsValid(why);
}

namespace {

// A block's offset plus an index within it, as a container index (both small and >= 0).
std::size_t indexAt(int offset, int i) {
  return static_cast<std::size_t>(offset) + static_cast<std::size_t>(i);
}

// Appends a printf-formatted warning (a skipped hold or run).
__attribute__((format(printf, 2, 3))) void warn(std::vector<std::string>* warnings,
                                                const char* format, ...) {
  char buf[256];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof(buf), format, args);
  va_end(args);
  warnings->emplace_back(buf);
}

// The recordings of one calibration: the main one first, then the extra legs.
std::vector<IndirectLeg> legsOf(const IndirectInput& in) {
  std::vector<IndirectLeg> legs{{in.imu, in.table, in.segments}};
  legs.insert(legs.end(), in.extra_legs.begin(), in.extra_legs.end());
  return legs;
}

// Why the recordings cannot be used, or "" when they can.
std::string checkLegs(const std::vector<IndirectLeg>& legs, const IndirectOptions& opt) {
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::string where = legs.size() > 1 ? "recording " + std::to_string(l + 1) + ": " : "";
    if (legs[l].imu.size() < 2) return where + "fewer than 2 IMU samples";
    if (legs[l].table.empty()) return where + "no table samples";
    const RecordingCheck check = checkIncrements(
        legs[l].imu, opt.checks,
        legs.size() > 1 ? "recording " + std::to_string(l + 1) : "recording", legs[l].segments);
    if (!check.ok) return check.message;
  }
  return "";
}

// Means and noise of the samples [a, b) of one hold.
Hold reduceHold(std::span<const nav::ImuSample> imu, std::size_t a, std::size_t b,
                const IndirectOptions& opt) {
  Hold h;
  Vec3 sum_a = Vec3::Zero(), sum_g = Vec3::Zero();
  for (std::size_t k = a; k < b; ++k) {
    sum_a += imu[k].dvel;
    sum_g += imu[k].dtheta;
  }
  const double T = imu[b - 1].t - intervalStart(imu, a);
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
    h.accel_sigma[i] = std::max(sa / std::sqrt(n), opt.min_accel_mean_sigma);
    h.gyro_sigma[i] = std::max(sg / std::sqrt(n), opt.min_gyro_mean_sigma);
    h.gyro_noise = std::max(h.gyro_noise, sg);
  }
  return h;
}

// Every usable static hold of every leg; skipped ones are named in warnings.
std::vector<Hold> collectHolds(const std::vector<IndirectLeg>& legs, const IndirectOptions& opt,
                               std::vector<std::string>* warnings) {
  std::vector<Hold> holds;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::span<const nav::ImuSample> imu = legs[l].imu;
    for (const Segment& seg : legs[l].segments) {
      if (seg.kind != SegmentKind::kStatic || !seg.recording) continue;
      const double t0 = seg.t0 + opt.static_margin_s;
      const double t1 = seg.t1 - opt.static_margin_s;
      if (t1 - t0 < opt.min_static_s) {
        warn(warnings, "hold '%s' (%.1f-%.1f s): shorter than %.1f s, skipped", seg.label.c_str(),
             seg.t0, seg.t1, opt.min_static_s + 2 * opt.static_margin_s);
        continue;
      }
      const std::size_t a = firstSampleStartingAt(imu, t0);
      const std::size_t b = endSampleEndingAt(imu, t1);
      if (b <= a + 2) {
        warn(warnings, "hold '%s' (%.1f-%.1f s): no IMU samples, skipped", seg.label.c_str(),
             seg.t0, seg.t1);
        continue;
      }
      Hold h = reduceHold(imu, a, b, opt);
      h.leg = static_cast<int>(l);
      h.segment = &seg;
      h.angles = holdAngles(legs[l].table, t0, t1);
      holds.push_back(h);
    }
  }
  return holds;
}

// The median per-sample gyro noise of the holds (weights of the runs).
double medianGyroNoise(const std::vector<Hold>& holds) {
  std::vector<double> noises;
  noises.reserve(holds.size());
  for (const Hold& h : holds) noises.push_back(h.gyro_noise);
  std::nth_element(noises.begin(), noises.begin() + static_cast<long>(noises.size() / 2),
                   noises.end());
  return noises[noises.size() / 2];
}

// The table's setting at a short rest next to a run (a settle segment too short to be a hold):
// the encoder angles over the part of the rest closest to the run. The navigation through the
// run starts (or ends) at this setting; the rest gives no static residual of its own.
const Hold* restAnchor(const IndirectLeg& leg, int l, const Segment& run, bool before,
                       const IndirectOptions& opt, std::deque<Hold>* anchors) {
  for (const Segment& s : leg.segments) {
    if (s.kind != SegmentKind::kStatic) continue;
    const double gap = before ? run.t0 - s.t1 : s.t0 - run.t1;
    if (std::abs(gap) > opt.adjacency_tolerance_s) continue;
    const double w = std::min(opt.anchor_window_s, s.t1 - s.t0);
    Hold h;
    h.leg = l;
    h.segment = &s;
    h.angles =
        before ? holdAngles(leg.table, s.t1 - w, s.t1) : holdAngles(leg.table, s.t0, s.t0 + w);
    anchors->push_back(h);
    return &anchors->back();
  }
  return nullptr;
}

// Every rotation run between two holds of the same leg (or short rests, restAnchor).
std::vector<Run> collectRuns(const std::vector<IndirectLeg>& legs, const std::vector<Hold>& holds,
                             const IndirectOptions& opt, std::deque<Hold>* anchors,
                             std::vector<std::string>* warnings) {
  std::vector<Run> runs;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const std::span<const nav::ImuSample> imu = legs[l].imu;
    const int leg = static_cast<int>(l);
    for (const Segment& seg : legs[l].segments) {
      if (seg.kind != SegmentKind::kRotate || !seg.recording) continue;
      const Hold* before = nullptr;
      const Hold* after = nullptr;
      for (const Hold& h : holds) {
        if (h.leg != leg) continue;
        if (std::abs(h.segment->t1 - seg.t0) <= opt.adjacency_tolerance_s) before = &h;
        if (std::abs(h.segment->t0 - seg.t1) <= opt.adjacency_tolerance_s) after = &h;
      }
      if (!before) before = restAnchor(legs[l], leg, seg, true, opt, anchors);
      if (!after) after = restAnchor(legs[l], leg, seg, false, opt, anchors);
      if (!before || !after) {
        warn(warnings, "run '%s' (%.1f-%.1f s): no usable hold %s it, skipped", seg.label.c_str(),
             seg.t0, seg.t1, before ? "after" : "before");
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
        warn(warnings, "run '%s': IMU data does not cover it, skipped", seg.label.c_str());
        continue;
      }
      r.t_start = intervalStart(imu, r.first);
      r.imu = imu;
      r.before = before;
      r.after = after;
      runs.push_back(r);
    }
  }
  return runs;
}

// The parameter blocks (model layout, calib/indirect/indirect_params.h) and which entries are
// estimated: free (estimated), held (at the start values by convention), in_model (false: not
// part of this table's chain).
struct Parameters {
  double accel[kTriadSize] = {};
  double gyro[kTriadSize] = {};
  double table[kTableSize] = {};
  std::vector<bool> free = std::vector<bool>(kParamCount, true);
  std::vector<bool> held = std::vector<bool>(kParamCount, false);
  std::vector<bool> in_model = std::vector<bool>(kParamCount, true);

  void hold(int g) {
    free[static_cast<std::size_t>(g)] = false;
    held[static_cast<std::size_t>(g)] = true;
  }
};

// Start values and the parameters held by the options' conventions.
Parameters initialParameters(const IndirectInput& in, const IndirectOptions& opt,
                             std::vector<std::string>* warnings) {
  Parameters p;
  const SensorModel start = in.start.value_or(SensorModel{});
  const auto accel0 = start.accel.block(), gyro0 = start.gyro.block();
  std::copy(accel0.begin(), accel0.end(), p.accel);
  std::copy(gyro0.begin(), gyro0.end(), p.gyro);
  TableErrors start_table;
  start_table.base_tilt = in.start_base_tilt;
  start_table.nonorthogonality = in.start_nonorthogonality;
  const auto axes0 = axesBlock(start_table);
  std::copy(axes0.begin(), axes0.end(), p.table);
  if (in.geometry.kind == TableKind::kTwoAxis) {
    for (int i : {kNonorthMiddleX, kNonorthMiddleY}) {
      p.hold(kTableOffset + i);
      p.in_model[indexAt(kTableOffset, i)] = false;
      p.table[i] = 0.0;
    }
  }
  if (!opt.estimate_base_tilt) {
    p.hold(kTableOffset + kTiltX);
    p.hold(kTableOffset + kTiltY);
  }
  if (!opt.estimate_nonorthogonality) {
    for (int i : {kNonorthInnerY, kNonorthMiddleX, kNonorthMiddleY}) p.hold(kTableOffset + i);
  }
  if (opt.gyro_reference == GyroReference::kStartValues) {
    if (in.start) {
      for (int i = 0; i < model::kMisCount; ++i) p.hold(kGyroOffset + kMis + i);
    } else {
      warnings->emplace_back(
          "no start values: gyro misalignments estimated from the runs (not from the direct "
          "calibration)");
    }
  }
  return p;
}

// What every outer iteration sees: the holds, the runs and the site.
struct Observations {
  std::vector<std::vector<Segment>> segments;  // per leg, merged and checked (holds point here)
  std::vector<Hold> holds;
  std::deque<Hold> anchors;  // short rests next to runs: settings only (restAnchor)
  std::vector<Run> runs;
  double gyro_noise = 0.0;
  double gravity = 0.0;
  Vec3 w_ie_L = Vec3::Zero();
};

// The residual blocks at the current parameters (the runs re-navigated at them).
// A residual block with where its data come from (for naming the largest residuals).
enum class ResidualGroup { kAccelHold, kGyroHold, kRun };

struct LabelledBlock {
  ceres::ResidualBlockId id = nullptr;
  std::string where;
  ResidualGroup group = ResidualGroup::kAccelHold;
};

std::string holdLabel(const Segment& s, const char* what) {
  char buf[200];
  std::snprintf(buf, sizeof(buf), "hold '%s' (%.1f-%.1f s) %s", s.label.c_str(), s.t0, s.t1, what);
  return buf;
}

// A run's end-attitude sigma about a horizontal axis: the gyro's angle random walk over it.
double runAngleSigma(const Observations& obs, const IndirectOptions& opt,
                     const RunPreintegration& pre) {
  return std::max(std::max(obs.gyro_noise, opt.min_gyro_noise) * pre.duration_s /
                      std::sqrt(std::max(pre.samples, 1)),
                  opt.min_run_angle_sigma);
}

// Which residuals enter a problem and with what weight: all, at their noise (the fit); each
// kind at 1 / factor^2 (the sigmas scaled by the measured residual); all but one hold or run
// (a jackknife resample).
struct ResidualSelection {
  std::array<double, 3> weight = {1.0, 1.0, 1.0};        // by ResidualGroup
  std::size_t skip_hold = static_cast<std::size_t>(-1);  // index into Observations::holds
  std::size_t skip_run = static_cast<std::size_t>(-1);   // index into Observations::runs
};

ceres::LossFunction* groupLoss(const ResidualSelection& sel, ResidualGroup g) {
  const double w = sel.weight[static_cast<std::size_t>(g)];
  return w == 1.0 ? nullptr : new ceres::ScaledLoss(nullptr, w, ceres::TAKE_OWNERSHIP);
}

void addResiduals(const IndirectInput& in, const IndirectOptions& opt, const Observations& obs,
                  Parameters* p, ceres::Problem* problem, std::vector<LabelledBlock>* blocks,
                  const ResidualSelection& sel = {}) {
  problem->AddParameterBlock(p->accel, kTriadSize);
  problem->AddParameterBlock(p->gyro, kTriadSize);
  problem->AddParameterBlock(p->table, kTableSize);
  for (std::size_t k = 0; k < obs.holds.size(); ++k) {
    if (k == sel.skip_hold) continue;
    const Hold& h = obs.holds[k];
    blocks->push_back(
        {problem->AddResidualBlock(StaticAccelCost::Create(h.accel_mean, in.geometry, h.angles,
                                                           obs.gravity, h.accel_sigma),
                                   groupLoss(sel, ResidualGroup::kAccelHold), p->accel, p->table),
         holdLabel(*h.segment, "accel"), ResidualGroup::kAccelHold});
    blocks->push_back(
        {problem->AddResidualBlock(
             StaticGyroCost::Create(h.gyro_mean, in.geometry, h.angles, obs.w_ie_L, h.gyro_sigma),
             groupLoss(sel, ResidualGroup::kGyroHold), p->gyro, p->table),
         holdLabel(*h.segment, "gyro"), ResidualGroup::kGyroHold});
  }
  for (std::size_t k = 0; k < obs.runs.size(); ++k) {
    if (k == sel.skip_run) continue;
    const Run& r = obs.runs[k];
    // Navigate from the start setting at the current table estimate.
    const Mat3 C_LP_start0 = platformAttitude(in.geometry, r.before->angles, p->table);
    const RunPreintegration pre = preintegrateRun(r.imu.subspan(r.first, r.last - r.first),
                                                  r.t_start, C_LP_start0, p->gyro, obs.w_ie_L);
    const double sigma_angle = runAngleSigma(obs, opt, pre);
    char buf[200];
    std::snprintf(buf, sizeof(buf), "run '%s' (%.1f-%.1f s)", r.segment->label.c_str(),
                  r.segment->t0, r.segment->t1);
    blocks->push_back(
        {problem->AddResidualBlock(RunCost::Create(pre, in.geometry, r.before->angles,
                                                   r.after->angles, C_LP_start0, sigma_angle),
                                   groupLoss(sel, ResidualGroup::kRun), p->gyro, p->table),
         buf, ResidualGroup::kRun});
  }
}

// Holds the entries that are not free (whole blocks constant, or a subset manifold).
void fixNonFree(const Parameters& p, double* block, int offset, int size, ceres::Problem* problem) {
  std::vector<int> fixed;
  for (int i = 0; i < size; ++i) {
    if (!p.free[indexAt(offset, i)]) fixed.push_back(i);
  }
  if (static_cast<int>(fixed.size()) == size) {
    problem->SetParameterBlockConstant(block);
  } else if (!fixed.empty()) {
    problem->SetManifold(block, new ceres::SubsetManifold(size, fixed));
  }
}

// Solves the problem; false (result->error set) when the solution is unusable.
bool solve(ceres::Problem* problem, const IndirectOptions::SolverSettings& settings,
           CalibrationResult* result) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = settings.max_iterations;
  so.function_tolerance = settings.function_tolerance;
  so.parameter_tolerance = settings.parameter_tolerance;
  so.gradient_tolerance = settings.gradient_tolerance;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
  result->solver_report = summary.BriefReport();
  if (!summary.IsSolutionUsable()) {
    result->status = FitStatus::Failed("Ceres solve failed: " + summary.message);
    return false;
  }
  const int nres = problem->NumResiduals();
  result->rms_normalised_residual = nres > 0 ? std::sqrt(2.0 * summary.final_cost / nres) : 0.0;
  return true;
}

// Standard deviations of every parameter from the covariance of the solved problem; false
// (result->status failed) when the information matrix is rank-deficient.
bool parameterSigmas(ceres::Problem* problem, Parameters* p, std::vector<double>* sigma,
                     CalibrationResult* result) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  co.num_threads = 1;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {
      {p->accel, p->accel}, {p->gyro, p->gyro}, {p->table, p->table}};
  if (!cov.Compute(blocks, problem)) {
    result->status =
        FitStatus::Failed("covariance could not be computed (rank-deficient information matrix: " +
                          result->conditioning.describe() + ")");
    return false;
  }
  double ca[kTriadSize * kTriadSize], cg[kTriadSize * kTriadSize], ct[kTableSize * kTableSize];
  cov.GetCovarianceBlock(p->accel, p->accel, ca);
  cov.GetCovarianceBlock(p->gyro, p->gyro, cg);
  cov.GetCovarianceBlock(p->table, p->table, ct);
  for (int i = 0; i < kTriadSize; ++i) {
    (*sigma)[indexAt(kAccelOffset, i)] = std::sqrt(std::max(ca[i * kTriadSize + i], 0.0));
    (*sigma)[indexAt(kGyroOffset, i)] = std::sqrt(std::max(cg[i * kTriadSize + i], 0.0));
  }
  for (int i = 0; i < kTableSize; ++i) {
    (*sigma)[indexAt(kTableOffset, i)] = std::sqrt(std::max(ct[i * kTableSize + i], 0.0));
  }
  return true;
}

// All parameters in one flat array ([accel | gyro | table], the global index order).
std::array<double, kParamCount> flatParameters(const Parameters& p) {
  std::array<double, kParamCount> v{};
  std::copy(p.accel, p.accel + kTriadSize, v.begin() + kAccelOffset);
  std::copy(p.gyro, p.gyro + kTriadSize, v.begin() + kGyroOffset);
  std::copy(p.table, p.table + kTableSize, v.begin() + kTableOffset);
  return v;
}

// Largest change of a free parameter over the iteration, in its sigmas.
double largestChangeInSigmas(const Parameters& p, const std::array<double, kParamCount>& before,
                             const std::vector<double>& sigma) {
  const std::array<double, kParamCount> now = flatParameters(p);
  double worst = 0.0;
  for (std::size_t g = 0; g < now.size(); ++g) {
    if (!p.free[g] || !(sigma[g] > 0.0)) continue;
    worst = std::max(worst, std::abs(now[g] - before[g]) / sigma[g]);
  }
  return worst;
}

// The coefficients, sigmas and flags of the result.
void report(const IndirectInput& in, const Parameters& p, const std::vector<double>& sigma,
            CalibrationResult* result) {
  CoefficientReport& rep = result->coefficients;
  rep.values.sensors.accel = TriadModel::fromBlock(p.accel);
  rep.values.sensors.gyro = TriadModel::fromBlock(p.gyro);
  rep.values.table.base_tilt = Vec2(p.table[kTiltX], p.table[kTiltY]);
  rep.values.table.nonorthogonality = {p.table[kNonorthInnerY], p.table[kNonorthMiddleX],
                                       p.table[kNonorthMiddleY]};
  rep.values.table_kind = in.geometry.kind;
  for (int i = 0; i < kParamCount; ++i) {
    const std::string name = parameterName(i);
    const std::size_t g = static_cast<std::size_t>(i);
    if (!p.in_model[g]) continue;
    if (p.free[g]) {
      rep.setSigma(name, sigma[g]);
      continue;
    }
    // Held or unobservable: the start value stays, with its own uncertainty if known.
    const auto it = in.start_uncertainty.find(name);
    if (it != in.start_uncertainty.end()) rep.uncertainty[name] = it->second;
    if (!p.held[g]) rep.setUnobservable(name);
  }
  // Navigation-based calibration cannot see the mounting: it is absorbed by the misalignments.
  rep.setUnobservable("table.mounting.x");
  rep.setUnobservable("table.mounting.y");
}

// Holds, runs and site of the input; false (result->status failed) when nothing is usable.
bool observe(const IndirectInput& in, const IndirectOptions& opt, Observations* obs,
             CalibrationResult* result) {
  std::vector<IndirectLeg> legs = legsOf(in);
  if (std::string why = checkLegs(legs, opt); !why.empty()) {
    result->status = FitStatus::Failed(std::move(why));
    return false;
  }
  // Holds split into settle + hold are one hold; segments contradicting the encoders named.
  obs->segments.reserve(legs.size());
  for (std::size_t l = 0; l < legs.size(); ++l) {
    SegmentCheckResult c =
        checkSegments(in.geometry.kind, legs[l].table, legs[l].segments, opt.segment_check);
    const std::string where = legs.size() > 1 ? "recording " + std::to_string(l + 1) + ": " : "";
    for (const std::string& n : c.notes) result->warnings.push_back(where + n);
    obs->segments.push_back(std::move(c.segments));
    legs[l].segments = obs->segments.back();
  }
  obs->gravity = nav::siteGravity(in.site);
  obs->w_ie_L = nav::earthRateL(in.site.latitude_rad);
  obs->holds = collectHolds(legs, opt, &result->warnings);
  if (obs->holds.empty()) {
    result->status =
        FitStatus::Failed("no usable static hold in the recording (need holds of at least " +
                          std::to_string(opt.min_static_s + 2 * opt.static_margin_s) + " s)");
    return false;
  }
  obs->gyro_noise = medianGyroNoise(obs->holds);
  obs->runs = collectRuns(legs, obs->holds, opt, &obs->anchors, &result->warnings);
  return true;
}

// The three largest residual blocks, normalised (RMS over the block's residuals, in sigmas).
std::vector<std::string> largestResiduals(ceres::Problem* problem,
                                          const std::vector<LabelledBlock>& blocks) {
  std::vector<std::pair<double, std::string>> v;
  for (const LabelledBlock& b : blocks) {
    double cost = 0.0;
    if (!problem->EvaluateResidualBlock(b.id, false, &cost, nullptr, nullptr)) continue;
    const int n = problem->GetCostFunctionForResidualBlock(b.id)->num_residuals();
    const double rms = std::sqrt(2.0 * cost / std::max(n, 1));
    char buf[48];
    std::snprintf(buf, sizeof(buf), ": %.1f sigma", rms);
    v.push_back({rms, b.where + buf});
  }
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> out;
  for (std::size_t k = 0; k < v.size() && k < 3; ++k) out.push_back(v[k].second);
  return out;
}

// The goodness of fit per kind of residual: the normalised RMS of the accelerometer holds, the
// gyro holds and the runs' end attitudes (0 where there are none).
void groupRms(ceres::Problem* problem, const std::vector<LabelledBlock>& blocks,
              CalibrationResult* result) {
  double ss[3] = {0.0, 0.0, 0.0};
  int n[3] = {0, 0, 0};
  for (const LabelledBlock& b : blocks) {
    double cost = 0.0;
    if (!problem->EvaluateResidualBlock(b.id, false, &cost, nullptr, nullptr)) continue;
    const auto g = static_cast<std::size_t>(b.group);
    ss[g] += 2.0 * cost;
    n[g] += problem->GetCostFunctionForResidualBlock(b.id)->num_residuals();
  }
  auto rms = [&](ResidualGroup g) {
    const auto k = static_cast<std::size_t>(g);
    return n[k] > 0 ? std::sqrt(ss[k] / n[k]) : 0.0;
  };
  result->accel_normalised_rms = rms(ResidualGroup::kAccelHold);
  result->gyro_normalised_rms = rms(ResidualGroup::kGyroHold);
  result->run_normalised_rms = rms(ResidualGroup::kRun);
}

// Fit quality of the result: residuals against the noise, every coefficient determined and
// plausible, rotation runs present.
void judgeIndirect(const Observations& obs, const IndirectOptions& opt,
                   std::vector<std::string> largest, CalibrationResult* result) {
  std::vector<std::string> reasons;
  if (result->rms_normalised_residual > opt.quality.max_normalised_rms) {
    char buf[200];
    std::snprintf(buf, sizeof(buf),
                  "normalised residual RMS %.3g (limit %.3g): the model does not fit the data, "
                  "the coefficients have absorbed what it lacks",
                  result->rms_normalised_residual, opt.quality.max_normalised_rms);
    reasons.push_back(buf);
  }
  if (obs.runs.empty()) {
    reasons.push_back(
        "no usable rotation run between two holds: the gyro scales are not "
        "determined by navigation");
  }
  judgeCoefficients(result->coefficients, opt.quality, &reasons);
  result->status = fitStatusFrom(std::move(reasons), std::move(largest));
  result->status.misfit = result->rms_normalised_residual > opt.quality.max_normalised_rms;
}

// Outer iterations: re-navigate the runs at the current parameters and re-solve until no
// parameter moves by more than outer_tolerance_sigma; false (result->status failed) on failure.
bool solveOuter(const IndirectInput& in, const IndirectOptions& opt, const Observations& obs,
                Parameters* p, std::vector<double>* sigma, CalibrationResult* result,
                std::vector<std::string>* largest, const ResidualSelection& sel = {}) {
  for (int outer = 0; outer < opt.max_outer_iterations; ++outer) {
    ceres::Problem problem;
    std::vector<LabelledBlock> blocks;
    addResiduals(in, opt, obs, p, &problem, &blocks, sel);
    if (outer == 0) {
      const Eigen::MatrixXd J = denseJacobian(problem, p->accel, p->gyro, p->table);
      result->conditioning = analyseInformation(J, &p->free, opt);
    }
    fixNonFree(*p, p->accel, kAccelOffset, kTriadSize, &problem);
    fixNonFree(*p, p->gyro, kGyroOffset, kTriadSize, &problem);
    fixNonFree(*p, p->table, kTableOffset, kTableSize, &problem);
    const std::array<double, kParamCount> before = flatParameters(*p);
    result->outer_iterations += 1;
    if (!solve(&problem, opt.solver, result)) return false;
    if (!parameterSigmas(&problem, p, sigma, result)) return false;
    *largest = largestResiduals(&problem, blocks);
    groupRms(&problem, blocks, result);
    if (largestChangeInSigmas(*p, before, *sigma) < opt.outer_tolerance_sigma) break;
  }
  return true;
}

// Gyro scales the runs determine much worse than the start values do (the direct calibration's
// rate runs: a turn about a vertical axis leaves no horizontal acceleration to navigate on)
// are held at the start values, with their sigma, and named; true when any was.
// "Much better": the start's sigma below a third of the runs' (comparable sigmas mean both
// sources see the scale; the refinement, which also sees the table errors, is then kept).
constexpr double kStartMuchBetter = 3.0;

bool holdBetterStartGyroScales(const IndirectInput& in, Parameters* p,
                               const std::vector<double>& sigma,
                               std::vector<std::string>* warnings) {
  if (!in.start) return false;
  const auto start = in.start->gyro.block();
  bool any = false;
  for (int i = 0; i < 3; ++i) {
    const int g = kGyroOffset + kScale + i;
    const std::size_t gi = static_cast<std::size_t>(g);
    const auto it = in.start_uncertainty.find(parameterName(g));
    if (!p->free[gi] || it == in.start_uncertainty.end() || !it->second.observable ||
        !it->second.sigma || !(kStartMuchBetter * *it->second.sigma < sigma[gi])) {
      continue;
    }
    p->gyro[kScale + i] = start[indexAt(kScale, i)];
    p->hold(g);
    warn(warnings,
         "%s: the runs determine it to %.3g, the start values (direct rate runs) to "
         "%.3g: the start value is kept",
         parameterName(g).c_str(), sigma[gi], *it->second.sigma);
    any = true;
  }
  return any;
}

// The sigmas scaled by the measured residual: each kind of residual weighted by its noise times
// max(1, its normalised RMS) in the covariance (the estimate stays the fit's).
void scaleSigmasByResidual(const IndirectInput& in, const IndirectOptions& opt,
                           const Observations& obs, Parameters* p, std::vector<double>* sigma,
                           CalibrationResult* result) {
  result->accel_sigma_factor = std::max(1.0, result->accel_normalised_rms);
  result->gyro_sigma_factor = std::max(1.0, result->gyro_normalised_rms);
  result->run_sigma_factor = std::max(1.0, result->run_normalised_rms);
  if (result->accel_sigma_factor == 1.0 && result->gyro_sigma_factor == 1.0 &&
      result->run_sigma_factor == 1.0) {
    return;
  }
  ResidualSelection sel;
  sel.weight = {1.0 / (result->accel_sigma_factor * result->accel_sigma_factor),
                1.0 / (result->gyro_sigma_factor * result->gyro_sigma_factor),
                1.0 / (result->run_sigma_factor * result->run_sigma_factor)};
  ceres::Problem problem;
  std::vector<LabelledBlock> blocks;
  addResiduals(in, opt, obs, p, &problem, &blocks, sel);
  fixNonFree(*p, p->accel, kAccelOffset, kTriadSize, &problem);
  fixNonFree(*p, p->gyro, kGyroOffset, kTriadSize, &problem);
  fixNonFree(*p, p->table, kTableOffset, kTableSize, &problem);
  std::vector<double> scaled(sigma->size(), 0.0);
  CalibrationResult scratch;
  if (parameterSigmas(&problem, p, &scaled, &scratch)) *sigma = std::move(scaled);
}

// Flat name -> value (or sigma) of every free parameter.
std::map<std::string, double> freeEntries(const Parameters& p, const double* values) {
  std::map<std::string, double> out;
  for (int g = 0; g < kParamCount; ++g) {
    if (p.free[static_cast<std::size_t>(g)]) out[parameterName(g)] = values[g];
  }
  return out;
}

// The jackknife, linearised: every hold (its accel and gyro residuals) and every run left out
// once, each resample's estimate one Gauss-Newton step from the full solution p with that
// unit's rows removed from the normal equations (exact for a linear model; the model is
// nearly linear near its solution: refitting each resample to convergence moved the ratios
// by < 0.05 on the writer's recordings at 30-50x the cost).
SigmaCheck jackknife(const IndirectInput& in, const IndirectOptions& opt, const Observations& obs,
                     const Parameters& full, const std::vector<double>& sigma) {
  SigmaCheck c;
  const std::size_t nh = obs.holds.size(), nr = obs.runs.size();
  if (static_cast<int>(nh + nr) < opt.sigma_check.min_resamples) {
    c.why_not = std::to_string(nh) + " holds and " + std::to_string(nr) + " runs: fewer than the " +
                std::to_string(opt.sigma_check.min_resamples) +
                " a leave-one-out estimate of the sigmas needs";
    return c;
  }
  Parameters p = full;
  ceres::Problem problem;
  std::vector<LabelledBlock> blocks;
  addResiduals(in, opt, obs, &p, &problem, &blocks);
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = {p.accel, p.gyro, p.table};
  std::vector<int> first_row = {0};  // of each block, in the blocks' order
  for (const LabelledBlock& b : blocks) {
    eo.residual_blocks.push_back(b.id);
    first_row.push_back(first_row.back() +
                        problem.GetCostFunctionForResidualBlock(b.id)->num_residuals());
  }
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  problem.Evaluate(eo, nullptr, &residuals, nullptr, &crs);
  std::vector<int> cols;  // the free parameters
  for (int g = 0; g < kParamCount; ++g) {
    if (p.free[static_cast<std::size_t>(g)]) cols.push_back(g);
  }
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, static_cast<Eigen::Index>(cols.size()));
  std::vector<int> col_of(kParamCount, -1);
  for (std::size_t k = 0; k < cols.size(); ++k)
    col_of[static_cast<std::size_t>(cols[k])] = static_cast<int>(k);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[static_cast<std::size_t>(r)];
         k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k) {
      const int col = col_of[static_cast<std::size_t>(crs.cols[static_cast<std::size_t>(k)])];
      if (col >= 0) J(r, col) += crs.values[static_cast<std::size_t>(k)];
    }
  }
  const Eigen::Map<const Eigen::VectorXd> r(residuals.data(),
                                            static_cast<Eigen::Index>(residuals.size()));
  const Eigen::MatrixXd N = J.transpose() * J;
  const Eigen::VectorXd g = J.transpose() * r;
  const std::array<double, kParamCount> theta = flatParameters(full);
  std::vector<std::map<std::string, double>> estimates;
  int failed = 0;
  // Unit u: hold u (blocks 2u, 2u+1) or run u - nh (block 2 nh + u - nh).
  for (std::size_t u = 0; u < nh + nr; ++u) {
    const std::size_t b0 = u < nh ? 2 * u : nh + u, b1 = u < nh ? b0 + 2 : b0 + 1;
    const Eigen::Index r0 = first_row[b0], nrows = first_row[b1] - first_row[b0];
    const Eigen::MatrixXd Ju = J.middleRows(r0, nrows);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(N - Ju.transpose() * Ju);
    const Eigen::VectorXd step = -ldlt.solve(g - Ju.transpose() * r.segment(r0, nrows));
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || !step.allFinite()) {
      ++failed;
      continue;
    }
    std::map<std::string, double> e;
    for (std::size_t k = 0; k < cols.size(); ++k) {
      e[parameterName(cols[k])] =
          theta[static_cast<std::size_t>(cols[k])] + step(static_cast<Eigen::Index>(k));
    }
    estimates.push_back(std::move(e));
  }
  c = compareSigmas(freeEntries(full, sigma.data()), jackknifeSigmas(estimates), opt.sigma_check);
  c.resamples = static_cast<int>(estimates.size());
  c.method =
      "jackknife: each of " + std::to_string(nh) + " holds and " + std::to_string(nr) +
      " runs left out once" +
      (failed ? " (" + std::to_string(failed) + " left the rest singular, not counted)" : "");
  if (c.resamples < opt.sigma_check.min_resamples) {
    c.done = false;
    c.why_not = "only " + std::to_string(c.resamples) +
                " of the leave-one-out resamples leave the parameters determined";
  }
  return c;
}

}  // namespace

// The calibration.
CalibrationResult calibrateIndirect(const IndirectInput& in, const IndirectOptions& opt) {
  CalibrationResult result;
  std::string why;
  if (!opt.IsValid(&why)) {
    result.status = FitStatus::Failed("invalid options: " + why);
    return result;
  }
  Observations obs;
  if (!observe(in, opt, &obs, &result)) return result;
  Parameters p = initialParameters(in, opt, &result.warnings);
  std::vector<double> sigma(kParamCount, 0.0);
  std::vector<std::string> largest;
  if (!solveOuter(in, opt, obs, &p, &sigma, &result, &largest)) return result;
  if (opt.prefer_start_gyro_scale && holdBetterStartGyroScales(in, &p, sigma, &result.warnings)) {
    if (!solveOuter(in, opt, obs, &p, &sigma, &result, &largest)) return result;
  }
  scaleSigmasByResidual(in, opt, obs, &p, &sigma, &result);
  report(in, p, sigma, &result);
  if (opt.sigma_check.enabled) {
    result.sigma_check = jackknife(in, opt, obs, p, sigma);
    raiseSigmas(&result.coefficients, &result.sigma_check);
  } else {
    result.sigma_check.why_not = "not asked for";
  }
  if (obs.runs.empty()) result.warnings.emplace_back("no usable rotation run: statics only");
  if (in.geometry.kind == TableKind::kThreeAxis) {
    result.warnings.emplace_back(
        "table.nonorthogonality.middle_x is the combination nu1_x + m0 (the middle encoder "
        "zero turns about the same axis): the data cannot tell the two apart; base tilt and "
        "middle_y are estimated separately");
  }
  judgeIndirect(obs, opt, std::move(largest), &result);
  return result;
}

IndirectJacobian indirectJacobian(const IndirectInput& in, const IndirectOptions& opt) {
  IndirectJacobian out;
  CalibrationResult result;
  Observations obs;
  std::string why;
  if (!opt.IsValid(&why) || !observe(in, opt, &obs, &result)) {
    out.status = Status::Error(why.empty() ? result.status.message : why);
    return out;
  }
  Parameters p = initialParameters(in, opt, &result.warnings);
  ceres::Problem problem;
  std::vector<LabelledBlock> blocks;
  addResiduals(in, opt, obs, &p, &problem, &blocks);
  const Eigen::MatrixXd J = denseJacobian(problem, p.accel, p.gyro, p.table);
  for (int g = 0; g < kParamCount; ++g) {
    if (!p.in_model[static_cast<std::size_t>(g)]) continue;
    out.names.push_back(parameterName(g));
    out.jacobian.conservativeResize(J.rows(), out.jacobian.cols() + 1);
    out.jacobian.col(out.jacobian.cols() - 1) = J.col(g);
  }
  out.status = Status::Ok();
  return out;
}

Result<std::vector<RunAttitudeResidual>> indirectRunResiduals(const IndirectInput& in,
                                                              const IndirectOptions& opt) {
  CalibrationResult result;
  Observations obs;
  std::string why;
  if (!opt.IsValid(&why) || !observe(in, opt, &obs, &result)) {
    return Result<std::vector<RunAttitudeResidual>>::Error(why.empty() ? result.status.message
                                                                       : why);
  }
  Parameters p = initialParameters(in, opt, &result.warnings);
  Result<std::vector<RunAttitudeResidual>> out;
  for (const Run& r : obs.runs) {
    const Mat3 C_LP_start0 = platformAttitude(in.geometry, r.before->angles, p.table);
    const RunPreintegration pre = preintegrateRun(r.imu.subspan(r.first, r.last - r.first),
                                                  r.t_start, C_LP_start0, p.gyro, obs.w_ie_L);
    const double sigma = runAngleSigma(obs, opt, pre);
    const RunCost cost(pre, in.geometry, r.before->angles, r.after->angles, C_LP_start0, sigma);
    double residual[2] = {};
    cost(p.gyro, p.table, residual);
    RunAttitudeResidual a;
    a.label = r.segment->label;
    a.t0 = r.segment->t0;
    a.t1 = r.segment->t1;
    a.tilt_rad = Vec2(residual[0], residual[1]) * sigma;
    a.sigma_rad = sigma;
    out.value.push_back(a);
  }
  return out;
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
