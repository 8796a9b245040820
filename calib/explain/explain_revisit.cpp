#include "calib/explain/explain_revisit.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "nav/rotation.h"

namespace imubench::calib {
namespace {

// A visit: consecutive static bins of one segment with one gravity direction.
struct Visit {
  std::size_t first = 0, last = 0;                  // bins [first, last]
  Eigen::Vector3d f_sum = Eigen::Vector3d::Zero();  // duration-weighted accelerometer readings
  double duration = 0.0;
};

// The mean residual of bins [first, last] on a channel and its sigma (as locateWindows: the
// noise floor's deviation of a mean over the duration and the interpolation's, which does not
// average down).
struct Mean {
  double value = 0.0, sigma = 0.0, t0 = 0.0, t1 = 0.0;
};

Mean meanOver(const std::vector<ExplainBin>& bins, const std::vector<double>& r,
              const std::vector<double>& model_sigma, const NoiseFloor& nf, std::size_t first,
              std::size_t last, int c) {
  double T = 0.0, sum = 0.0, model = 0.0;
  for (std::size_t b = first; b <= last; ++b) {
    const double dt = bins[b].duration();
    T += dt;
    sum += r[b * 6 + static_cast<std::size_t>(c)] * dt;
    model += model_sigma[b * 6 + static_cast<std::size_t>(c)] * dt;
  }
  return {sum / T, std::hypot(nf.sigmaOfMean(c, T), model / T), bins[first].t0, bins[last].t1};
}

Eigen::Vector3d accelOf(const ExplainBin& b) {
  return {b.measured[0], b.measured[1], b.measured[2]};
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

std::vector<Visit> visitsOf(const std::vector<ExplainBin>& bins, const RevisitOptions& o) {
  constexpr double kMaxGapS = 1.0;  // a longer gap between bins ends a visit (samples missing)
  std::vector<Visit> out;
  bool open = false;
  for (std::size_t b = 0; b < bins.size(); ++b) {
    const ExplainBin& bin = bins[b];
    if (bin.moving) {
      open = false;
      continue;
    }
    const Eigen::Vector3d f = accelOf(bin);
    if (open) {
      const Visit& v = out.back();
      const ExplainBin& prev = bins[v.last];
      open = v.last + 1 == b && prev.segment == bin.segment && bin.t0 - prev.t1 <= kMaxGapS &&
             angleBetween(v.f_sum, f) <= o.same_attitude_rad;
    }
    if (!open) out.push_back({b, b});
    Visit& v = out.back();
    v.last = b;
    v.f_sum += f * bin.duration();
    v.duration += bin.duration();
    open = true;
  }
  return out;
}

const char* unitOf(int channel) {
  return channel < 3 ? "m/s^2" : "rad/s";
}

std::string timeChange(const Mean& other, double angle, double diff, double z, int c) {
  char buf[320];
  std::snprintf(buf, sizeof(buf),
                "; the same attitude (gravity within %.1f deg) held at %.1f-%.1f s reads %.3g %s "
                "differently (%.1f sigma): the residual changes with time at one attitude, which "
                "no term of the attitude does (a bias drift, bias_instability, a warm-up or a "
                "step)",
                angle * kRadToDeg, other.t0, other.t1, diff, unitOf(c), z);
  return buf;
}

std::string sameResidual(const Mean& other, double angle, double z) {
  char buf[240];
  std::snprintf(buf, sizeof(buf),
                "; the same attitude (gravity within %.1f deg) held at %.1f-%.1f s shows it too "
                "(%.1f sigma apart): it repeats with the attitude (a term of the attitude the "
                "library lacks, or a drift slower than the time between the two)",
                angle * kRadToDeg, other.t0, other.t1, std::abs(z));
  return buf;
}

// The window's finding against the visits of its attitude, or "" when no visit compares.
std::string revisitFinding(const std::vector<ExplainBin>& bins, const std::vector<double>& r,
                           const std::vector<double>& model_sigma, const NoiseFloor& nf,
                           double significance, const RevisitOptions& o,
                           const std::vector<Visit>& visits, const ExplainWindow& w) {
  // The window's part in the visit it overlaps most (a window can start or end on a bin where
  // the table already turns, or span several segments once merged); none: unjudged.
  const Visit* own = nullptr;
  std::size_t first = 0, last = 0;
  double best = 0.0;
  for (const Visit& v : visits) {
    std::size_t a = v.last + 1, e = v.first;
    for (std::size_t b = v.first; b <= v.last; ++b) {
      if (bins[b].t1 <= w.t0 || bins[b].t0 >= w.t1) continue;
      a = std::min(a, b);
      e = b;
    }
    if (a > e) continue;
    const double T = bins[e].t1 - bins[a].t0;
    if (T > best) {
      best = T;
      own = &v;
      first = a;
      last = e;
    }
  }
  if (!own || best < o.min_visit_s) return "";
  Eigen::Vector3d f_sum = Eigen::Vector3d::Zero();
  for (std::size_t b = first; b <= last; ++b) f_sum += accelOf(bins[b]) * bins[b].duration();
  const Mean mw = meanOver(bins, r, model_sigma, nf, first, last, w.channel);
  double best_time_z = 0.0, best_same_z = std::numeric_limits<double>::infinity();
  std::string time_text, same_text;
  for (const Visit& v : visits) {
    if (&v == own) continue;
    if (v.duration < o.min_visit_s) continue;
    const double angle = angleBetween(v.f_sum, f_sum);
    if (angle > o.same_attitude_rad) continue;
    const Mean mv = meanOver(bins, r, model_sigma, nf, v.first, v.last, w.channel);
    const double diff = mw.value - mv.value;
    const double z = diff / std::hypot(mw.sigma, mv.sigma);
    const double larger = std::max(std::abs(mw.value), std::abs(mv.value));
    if (std::abs(z) >= significance && std::abs(diff) >= o.min_change_fraction * larger &&
        std::abs(z) > best_time_z) {
      best_time_z = std::abs(z);
      time_text = timeChange(mv, angle, diff, z, w.channel);
    }
    if (std::abs(z) <= o.same_sigma && std::abs(mv.value) >= significance * mv.sigma &&
        std::abs(z) < best_same_z) {
      best_same_z = std::abs(z);
      same_text = sameResidual(mv, angle, z);
    }
  }
  return time_text.empty() ? same_text : time_text;
}

}  // namespace

void nameRevisits(const std::vector<ExplainBin>& bins, const std::vector<double>& r,
                  const std::vector<double>& model_sigma, const NoiseFloor& nf, double significance,
                  const RevisitOptions& o, std::vector<ExplainWindow>* windows) {
  const std::vector<Visit> visits = visitsOf(bins, o);
  for (ExplainWindow& w : *windows) {
    w.reason += revisitFinding(bins, r, model_sigma, nf, significance, o, visits, w);
  }
}

}  // namespace imubench::calib
