#include "calib/thermal/thermal_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "calib/thermal/thermal_fit_detail.h"
#include "calib/thermal_model.h"

namespace imubench::calib {
namespace {
constexpr const char* kAxes[3] = {"x", "y", "z"};
}  // namespace

namespace thermal_detail {
namespace {

// One candidate model's solution: coefficients in physical units and their covariance.
struct Candidate {
  int order = 0;
  bool hysteresis = false;
  double chi2 = 0.0;
  double bic = std::numeric_limits<double>::infinity();
  Eigen::VectorXd x;  // poly[0..order], then h
  Eigen::MatrixXd cov;
};

// Least squares of one (order, hysteresis) model; columns scaled by `scale` (degC) and the
// largest |rate| for conditioning, unscaled afterwards.
Candidate solveCandidate(const CoefficientData& d, int order, bool hysteresis, double scale,
                         double rate_scale, bool known_sigma) {
  const int n = static_cast<int>(d.value.size());
  const int p = order + 1 + (hysteresis ? 1 : 0);
  Eigen::MatrixXd A(n, p);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const std::size_t u = static_cast<std::size_t>(i);
    const double w = (d.gain.empty() ? 1.0 : d.gain[u]) / d.sigma[u];
    double xk = 1.0;
    for (int k = 0; k <= order; ++k, xk *= d.dT[u] / scale) A(i, k) = w * xk;
    if (hysteresis) A(i, order + 1) = w * d.rate[u] / rate_scale;
    b(i) = d.value[u] / d.sigma[u];
  }
  Candidate c;
  c.order = order;
  c.hysteresis = hysteresis;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < p) return c;  // not determined: infinite BIC
  Eigen::VectorXd xs = qr.solve(b);
  c.chi2 = (A * xs - b).squaredNorm();
  // BIC with the points' sigmas known up to one common factor (estimated): robust to the
  // per-point sigmas being uniformly too small or too large. With too few points to estimate
  // that factor, the sigmas as given.
  const double nd = static_cast<double>(n);
  c.bic = known_sigma ? c.chi2 + p * std::log(nd)
                      : nd * std::log(std::max(c.chi2, 1e-300) / nd) + p * std::log(nd);
  Eigen::MatrixXd cov = (A.transpose() * A).inverse();
  Eigen::VectorXd unscale(p);
  for (int k = 0; k <= order; ++k) unscale(k) = std::pow(scale, -k);
  if (hysteresis) unscale(order + 1) = 1.0 / rate_scale;
  c.x = unscale.asDiagonal() * xs;
  c.cov = unscale.asDiagonal() * cov * unscale.asDiagonal();
  return c;
}

// The candidate's highest polynomial term (order >= 1) and dT/dt term exceed k sigmas
// (sigmas scaled by sqrt(reduced chi^2) when above 1).
bool significant(const Candidate& c, int n, double k) {
  if (!std::isfinite(c.bic)) return false;
  const int p = static_cast<int>(c.x.size());
  const double birge = std::max(1.0, std::sqrt(c.chi2 / std::max(1, n - p)));
  const auto strong = [&](int i) { return std::abs(c.x(i)) > k * birge * std::sqrt(c.cov(i, i)); };
  if (c.order >= 1 && !strong(c.order)) return false;
  return !c.hysteresis || strong(p - 1);
}

}  // namespace

// Distinct temperatures among sorted values (closer than `same` count as one).
int distinctTemperatures(std::vector<double> t, double same) {
  std::sort(t.begin(), t.end());
  int n = 0;
  double last = -std::numeric_limits<double>::infinity();
  for (double v : t) {
    if (v - last > same) {
      ++n;
      last = v;
    }
  }
  return n;
}

// Chooses and fits the model of one coefficient; false (why) when it cannot be fitted.
bool fitCoefficient(const CoefficientData& d, const FitContext& ctx, model::ThermalCoefficient* out,
                    ThermalCoefficientFit* fit, std::string* why) {
  const ThermalFitOptions& o = *ctx.options;
  const int n = static_cast<int>(d.value.size());
  fit->points = n;
  const int distinct = distinctTemperatures(d.dT, o.same_temperature_c);
  if (distinct < 2) {
    *why = fit->name + ": observable at " + std::to_string(distinct) +
           " distinct temperature(s); a thermal model needs at least 2";
    return false;
  }
  const int max_order = std::min(o.order >= 0 ? o.order : o.max_order, distinct - 1);
  const int min_order = o.order >= 0 ? max_order : 0;
  // Few points (no residual left for the largest model): BIC with the sigmas as given, and
  // models may interpolate the points exactly (two temperatures: a straight line).
  const bool few = n <= max_order + 2 + (ctx.hysteresis ? 1 : 0);
  Candidate best;
  for (int order = min_order; order <= max_order; ++order) {
    for (bool h : {false, true}) {
      if (h && !ctx.hysteresis) continue;
      const int p = order + 1 + (h ? 1 : 0);
      if (p > n || (p == n && !few && p > 1)) continue;
      Candidate c = solveCandidate(d, order, h, ctx.scale, ctx.rate_scale, few);
      if (c.bic < best.bic && ((order == min_order && !h) || significant(c, n, o.min_term_sigma))) {
        best = std::move(c);
      }
    }
  }
  if (!std::isfinite(best.bic)) {
    *why = fit->name + ": the points do not determine any polynomial";
    return false;
  }
  const int p = static_cast<int>(best.x.size());
  const double dof = std::max(1, n - p);
  fit->chi2 = best.chi2;
  fit->bic = best.bic;
  fit->birge = std::max(1.0, std::sqrt(best.chi2 / dof));
  *out = {};
  out->order = best.order;
  out->hysteresis = best.hysteresis;
  for (int k = 0; k <= best.order; ++k) {
    out->poly[static_cast<std::size_t>(k)] = best.x(k);
    out->sigma_poly[static_cast<std::size_t>(k)] = fit->birge * std::sqrt(best.cov(k, k));
  }
  if (best.hysteresis) {
    out->dTdt = best.x(p - 1);
    out->sigma_dTdt = fit->birge * std::sqrt(best.cov(p - 1, p - 1));
  }
  return true;
}

}  // namespace thermal_detail

using thermal_detail::CoefficientData;
using thermal_detail::distinctTemperatures;
using thermal_detail::fitCoefficient;
using thermal_detail::FitContext;

std::string thermalCoefficientName(const std::string& triad, int index) {
  if (index < model::kBias) return triad + ".scale." + kAxes[index - model::kScale];
  if (index < model::kMis) return triad + ".bias." + kAxes[index - model::kBias];
  return triad + ".misalignment." +
         model::kMisEntries[static_cast<std::size_t>(index - model::kMis)].name;
}

bool ThermalFitOptions::IsValid(std::string* why) const {
  auto bad = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (order < -1 || order > model::kMaxThermalOrder) return bad("order must be auto or 0..4");
  if (max_order < 0 || max_order > model::kMaxThermalOrder) return bad("max_order must be 0..4");
  if (!std::isfinite(t_ref_c)) return bad("t_ref_c must be finite");
  if (!(same_temperature_c > 0.0)) return bad("same_temperature_c must be > 0");
  if (!(min_hysteresis_rate > 0.0)) return bad("min_hysteresis_rate must be > 0");
  if (!(relative_sigma_floor >= 0.0)) return bad("relative_sigma_floor must be >= 0");
  if (!(min_term_sigma >= 0.0)) return bad("min_term_sigma must be >= 0");
  return true;
}

ThermalFitResult fitThermal(const std::vector<ThermalFitPoint>& points,
                            const ThermalFitOptions& options) {
  ThermalFitResult r;
  if (std::string why; !options.IsValid(&why)) {
    r.status = FitStatus::Failed(std::move(why));
    return r;
  }
  std::vector<double> temps;
  bool heating = false, cooling = false;
  for (const ThermalFitPoint& p : points) {
    if (!std::isfinite(p.temp_c) || !std::isfinite(p.temp_rate)) {
      r.status = FitStatus::Failed(p.source + ": temperature or its rate is not finite");
      return r;
    }
    temps.push_back(p.temp_c);
    heating = heating || p.temp_rate > options.min_hysteresis_rate;
    cooling = cooling || p.temp_rate < -options.min_hysteresis_rate;
  }
  r.distinct_temperatures = distinctTemperatures(temps, options.same_temperature_c);
  if (r.distinct_temperatures < 2) {
    r.status =
        FitStatus::Failed("a single temperature point (" + std::to_string(points.size()) +
                          " calibration(s) within " + std::to_string(options.same_temperature_c) +
                          " degC): a thermal model needs at least two temperatures");
    return r;
  }
  r.hysteresis_candidate = heating && cooling;
  FitContext ctx{&options};
  ctx.hysteresis = r.hysteresis_candidate;
  ctx.scale = 1.0;
  ctx.rate_scale = options.min_hysteresis_rate;
  for (const ThermalFitPoint& p : points) {
    ctx.scale = std::max(ctx.scale, std::abs(p.temp_c - options.t_ref_c));
    ctx.rate_scale = std::max(ctx.rate_scale, std::abs(p.temp_rate));
  }
  model::ThermalCoefficients& c = r.coefficients;
  c.t_ref_c = options.t_ref_c;
  c.t_min_c = *std::min_element(temps.begin(), temps.end());
  c.t_max_c = *std::max_element(temps.begin(), temps.end());
  for (const bool accel : {true, false}) {
    for (int i = 0; i < model::kTriadSize; ++i) {
      const std::size_t u = static_cast<std::size_t>(i);
      CoefficientData d;
      for (const ThermalFitPoint& p : points) {
        if (!(accel ? p.observable_accel : p.observable_gyro)[u]) continue;
        const double v = (accel ? p.accel : p.gyro)[u];
        const double s = (accel ? p.sigma_accel : p.sigma_gyro)[u];
        d.dT.push_back(p.temp_c - options.t_ref_c);
        d.rate.push_back(p.temp_rate);
        d.value.push_back(v);
        d.sigma.push_back(std::max(s, options.relative_sigma_floor * std::abs(v) + 1e-15));
      }
      ThermalCoefficientFit fit;
      fit.name = thermalCoefficientName(accel ? "accel" : "gyro", i);
      model::ThermalCoefficient& out = (accel ? c.accel : c.gyro)[u];
      if (std::string why; !fitCoefficient(d, ctx, &out, &fit, &why)) {
        r.status = FitStatus::Failed(std::move(why));
        return r;
      }
      r.fits.push_back(fit);
    }
  }
  r.status = FitStatus();
  return r;
}

// ---- Points from one run ----------------------------------------------------------------

namespace {

// The blocks, sigmas and observability of a direct calibration's report.
void fillPoint(const CoefficientReport& rep, ThermalFitPoint* p) {
  const auto a = rep.values.sensors.accel.block();
  const auto g = rep.values.sensors.gyro.block();
  for (int i = 0; i < model::kTriadSize; ++i) {
    const std::size_t u = static_cast<std::size_t>(i);
    p->accel[u] = a[u];
    p->gyro[u] = g[u];
    for (const bool accel : {true, false}) {
      const auto it = rep.uncertainty.find(thermalCoefficientName(accel ? "accel" : "gyro", i));
      const bool obs = it == rep.uncertainty.end() || it->second.observable;
      const double s = it != rep.uncertainty.end() ? it->second.sigma.value_or(0.0) : 0.0;
      (accel ? p->observable_accel : p->observable_gyro)[u] = obs;
      (accel ? p->sigma_accel : p->sigma_gyro)[u] = s;
    }
  }
}

// Temperature statistics of the samples inside the used segments.
bool temperatureOf(const DirectCalibrationInput& run, const std::vector<Segment>& segs,
                   const std::vector<double>& rates, ThermalFitPoint* p) {
  double sum = 0.0, sum_rate = 0.0, lo = 0.0, hi = 0.0;
  std::size_t n = 0, k = 0;
  for (const Segment& s : segs) {
    if (s.kind != SegmentKind::kStatic && s.kind != SegmentKind::kRotate) continue;
    while (k < run.imu.size() && run.imu[k].t < s.t0) ++k;
    for (std::size_t i = k; i < run.imu.size() && run.imu[i].t <= s.t1; ++i) {
      const double T = run.imu[i].temp_c;
      if (!std::isfinite(T)) return false;
      sum += T;
      sum_rate += rates[i];
      lo = n == 0 ? T : std::min(lo, T);
      hi = n == 0 ? T : std::max(hi, T);
      ++n;
    }
  }
  if (n == 0) return false;
  p->temp_c = sum / static_cast<double>(n);
  p->temp_rate = sum_rate / static_cast<double>(n);
  p->temp_span_c = hi - lo;
  return true;
}

// The repetition a label names: its part before the last '/' ("" without one).
std::string repetitionOf(const std::string& label) {
  const std::size_t slash = label.rfind('/');
  return slash == std::string::npos ? std::string() : label.substr(0, slash);
}

// IMU temperature range (lo, hi) of the samples inside each segment (NaN, NaN: none).
std::vector<std::pair<double, double>> segmentTemperatures(const DirectCalibrationInput& run) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::pair<double, double>> out;
  for (const Segment& s : run.segments) {
    auto it = std::lower_bound(run.imu.begin(), run.imu.end(), s.t0,
                               [](const nav::ImuSample& a, double t) { return a.t < t; });
    double lo = nan, hi = nan;
    for (; it != run.imu.end() && it->t <= s.t1; ++it) {
      if (!std::isfinite(it->temp_c)) continue;
      lo = std::isfinite(lo) ? std::min(lo, it->temp_c) : it->temp_c;
      hi = std::isfinite(hi) ? std::max(hi, it->temp_c) : it->temp_c;
    }
    out.emplace_back(lo, hi);
  }
  return out;
}

// The segments of each temperature point (rules 1-3 of thermal_fit.h), in time order.
std::vector<std::vector<Segment>> pointGroups(const DirectCalibrationInput& run,
                                              double max_span_c) {
  const auto temps = segmentTemperatures(run);
  std::vector<std::vector<Segment>> groups(1);
  std::string rep;
  double lo = 0.0, hi = 0.0;
  auto open = [&] {
    if (!groups.back().empty()) groups.emplace_back();
  };
  for (std::size_t i = 0; i < run.segments.size(); ++i) {
    const Segment& s = run.segments[i];
    if (s.kind == SegmentKind::kSoak) {  // rule 1
      open();
      continue;
    }
    const std::string r = repetitionOf(s.label);
    const auto [slo, shi] = temps[i];
    const bool has_t = std::isfinite(slo);
    if (!groups.back().empty()) {
      const bool new_rep = !r.empty() && r != rep;                      // rule 2
      const bool too_wide = r.empty() && has_t && std::isfinite(lo) &&  // rule 3
                            std::max(hi, shi) - std::min(lo, slo) > max_span_c;
      if (new_rep || too_wide) open();
    }
    if (groups.back().empty() || !std::isfinite(lo)) {
      lo = slo;
      hi = shi;
    } else if (has_t) {
      lo = std::min(lo, slo);
      hi = std::max(hi, shi);
    }
    rep = r;
    groups.back().push_back(s);
  }
  if (groups.back().empty()) groups.pop_back();
  return groups;
}

// The samples of [t0, t1] moved through `ref` from their own (T, Tdot) to (T_p, Tdot_p):
// the true increments at the sample's coefficients, read again with the point's.
void referToPoint(const model::ThermalCoefficients& ref, const std::vector<double>& rates,
                  double t0, double t1, const ThermalFitPoint& p, nav::ImuSamples* imu) {
  std::array<double, model::kTriadSize> a_p{}, g_p{}, a{}, g{};
  model::thermalTriadBlock(ref, ref.accel, p.temp_c, p.temp_rate, a_p.data());
  model::thermalTriadBlock(ref, ref.gyro, p.temp_c, p.temp_rate, g_p.data());
  for (std::size_t k = 1; k < imu->size(); ++k) {
    nav::ImuSample& s = (*imu)[k];
    if (s.t < t0 || s.t > t1 + 1.0 || !std::isfinite(s.temp_c)) continue;
    const double dt = s.t - (*imu)[k - 1].t;
    model::thermalTriadBlock(ref, ref.accel, s.temp_c, rates[k], a.data());
    model::thermalTriadBlock(ref, ref.gyro, s.temp_c, rates[k], g.data());
    Mat3 G;
    Vec3 h;
    model::compensationAffine(a.data(), &G, &h);
    const Vec3 dv = G * s.dvel + h * dt;  // true increment
    model::compensationAffine(g.data(), &G, &h);
    const Vec3 dth = G * s.dtheta + h * dt;
    // reading() is affine in the input: S (M u - b); for increments S (M du - b dt).
    s.dvel = model::reading(a_p.data(), Vec3(dv / dt)) * dt;
    s.dtheta = model::reading(g_p.data(), Vec3(dth / dt)) * dt;
  }
}

}  // namespace

bool ThermalPointOptions::IsValid(std::string* why) const {
  if (!(max_point_span_c > 0.0)) {
    if (why) *why = "max_point_span_c must be > 0";
    return false;
  }
  return true;
}

ThermalPointsResult thermalPointsFromRun(const DirectCalibrationInput& run,
                                         const std::string& source,
                                         const ThermalPointOptions& options) {
  ThermalPointsResult r;
  const bool any_temp = std::any_of(run.imu.begin(), run.imu.end(), [](const nav::ImuSample& s) {
    return std::isfinite(s.temp_c);
  });
  if (!any_temp) {
    r.status = Status::Error(source +
                             ": the recording has no IMU temperatures (imu.csv temp column empty)");
    return r;
  }
  if (std::string why; !options.IsValid(&why)) {
    r.status = Status::Error(std::move(why));
    return r;
  }
  const std::vector<double> rates = temperatureRates(run.imu);
  const std::vector<std::vector<Segment>> groups = pointGroups(run, options.max_point_span_c);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    ThermalFitPoint p;
    p.source = source + " point " + std::to_string(g + 1) + " (segments from '" +
               groups[g].front().label + "')";
    if (!temperatureOf(run, groups[g], rates, &p)) {
      r.status = Status::Error(
          p.source + ": samples without temperature (imu.csv temp empty) in its segments");
      return r;
    }
    DirectCalibrationInput in = run;
    in.segments = groups[g];
    if (options.reference) {
      referToPoint(*options.reference, rates, groups[g].front().t0, groups[g].back().t1, p,
                   &in.imu);
    }
    const DirectCalibrationResult cal = calibrateDirect(in, options.direct);
    if (!cal.status.IsSolutionUsable()) {
      r.status =
          Status::Error(p.source + ": direct calibration " +
                        (cal.status.HasResult() ? "unusable: " : "failed: ") + cal.status.message);
      return r;
    }
    fillPoint(cal.report, &p);
    r.points.push_back(p);
  }
  r.status = Status::Ok();
  return r;
}

}  // namespace imubench::calib

namespace imubench::calib {

bool ThermalRunsFitOptions::IsValid(std::string* why) const {
  auto bad = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!fit.IsValid(why) || !points.IsValid(why)) return false;
  if (refinements < 0 || refinements > 10) return bad("refinements must be 0..10");
  if (!(max_normalised_rms_before_last > 0.0)) return bad("max_normalised_rms_before_last > 0");
  return true;
}

ThermalRunsFitResult fitThermalRuns(const std::vector<ThermalRun>& runs,
                                    const ThermalRunsFitOptions& options) {
  ThermalRunsFitResult r;
  if (std::string why; !options.IsValid(&why)) {
    r.status = FitStatus::Failed(std::move(why));
    return r;
  }
  model::ThermalCoefficients previous;
  for (int pass = 0; pass <= options.refinements; ++pass) {
    ThermalPointOptions po = options.points;
    if (pass < options.refinements) {
      po.direct.quality = po.direct.quality.acceptingMisfit(options.max_normalised_rms_before_last);
    }
    if (pass > 0) po.reference = &previous;
    r.points.clear();
    for (const ThermalRun& run : runs) {
      const ThermalPointsResult p = thermalPointsFromRun(run.input, run.source, po);
      if (!p.status.ok) {
        r.status = FitStatus::Failed(
            p.status.message + (pass > 0 ? " (refinement pass " + std::to_string(pass) + ")" : ""));
        return r;
      }
      r.points.insert(r.points.end(), p.points.begin(), p.points.end());
    }
    r.fit = fitThermal(r.points, options.fit);
    r.passes = pass + 1;
    if (!r.fit.status.HasResult()) {
      r.status = r.fit.status;
      return r;
    }
    previous = r.fit.coefficients;
    // The end points' samples lie up to half a point's span outside the points' mean
    // temperatures: the correction extrapolates the polynomial that far instead of clamping.
    previous.t_min_c -= options.points.max_point_span_c;
    previous.t_max_c += options.points.max_point_span_c;
  }
  r.status = r.fit.status;
  return r;
}

}  // namespace imubench::calib
