#include "calib/static_detection.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "calib/option_check.h"

namespace imubench::calib {

const char* recordingStatusName(RecordingStatusCode code) {
  switch (code) {
    case RecordingStatusCode::kOk:
      return "ok";
    case RecordingStatusCode::kBadOptions:
      return "bad options";
    case RecordingStatusCode::kEmpty:
      return "empty recording";
    case RecordingStatusCode::kSizeMismatch:
      return "size mismatch";
    case RecordingStatusCode::kNonFinite:
      return "non-finite sample";
    case RecordingStatusCode::kTimeNotIncreasing:
      return "time not increasing";
    case RecordingStatusCode::kMissingSegment:
      return "missing segment";
    case RecordingStatusCode::kSaturated:
      return "saturated sample";
    case RecordingStatusCode::kTooShortStatic:
      return "static interval too short";
    case RecordingStatusCode::kTooFewStatics:
      return "too few static intervals";
  }
  return "unknown";
}

bool StaticDetectionOptions::IsValid(std::string* why) const {
  if (!(window_s > 0.0)) return invalidOption(why, "window_s must be > 0");
  if (!(quiet_quantile > 0.0 && quiet_quantile < 1.0))
    return invalidOption(why, "quiet_quantile must be in (0, 1)");
  if (!(threshold_factor > 1.0)) return invalidOption(why, "threshold_factor must be > 1");
  if (!(min_duration_s >= 0.0)) return invalidOption(why, "min_duration_s must be >= 0");
  return true;
}

bool RecordingCheckOptions::IsValid(std::string* why) const {
  if (!(max_gap_factor > 1.0)) {
    if (why) *why = "max_gap_factor must be > 1";
    return false;
  }
  return true;
}

namespace {

std::string where(const RawImuData& d, std::size_t i) {
  std::ostringstream s;
  s << "sample " << i;
  if (i < d.t.size() && std::isfinite(d.t[i])) s << " (t = " << d.t[i] << " s)";
  return s.str();
}

// Median of the values (taken by value: reordered); 0 for none.
double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double medianStep(const std::vector<double>& t) {
  std::vector<double> dt;
  dt.reserve(t.size());
  for (std::size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
  return median(std::move(dt));
}

// Centred moving-window total variance (sum over axes) of a vector series, half-width `half`.
// The sums are taken block by block about a reference inside the block (its first sample), so
// their rounding is at the scale of the data within a few windows, not of the whole series:
// identical readings give exactly 0 and a static window far from motion is never swamped by
// the rounding of large sums (the running sums of a whole recording are not).
std::vector<double> windowVariance(const std::vector<Vec3>& v, std::size_t half) {
  const std::size_t n = v.size();
  std::vector<double> out(n, 0.0);
  const std::size_t block = std::max<std::size_t>(half, 1);
  std::vector<Vec3> s1;
  std::vector<double> s2;
  for (std::size_t c0 = 0; c0 < n; c0 += block) {
    const std::size_t c1 = std::min(n, c0 + block);  // centres [c0, c1)
    const std::size_t lo = c0 >= half ? c0 - half : 0;
    const std::size_t hi = std::min(n, c1 + half);  // samples [lo, hi)
    const Vec3& ref = v[c0];
    s1.assign(hi - lo + 1, Vec3::Zero());
    s2.assign(hi - lo + 1, 0.0);
    for (std::size_t i = lo; i < hi; ++i) {
      const Vec3 x = v[i] - ref;
      s1[i - lo + 1] = s1[i - lo] + x;
      s2[i - lo + 1] = s2[i - lo] + x.squaredNorm();
    }
    for (std::size_t i = c0; i < c1; ++i) {
      const std::size_t a = (i >= half ? i - half : 0) - lo;
      const std::size_t b = std::min(n, i + half + 1) - lo;
      const double m = static_cast<double>(b - a);
      const Vec3 mean = (s1[b] - s1[a]) / m;
      out[i] = std::max(0.0, (s2[b] - s2[a]) / m - mean.squaredNorm());
    }
  }
  return out;
}

// The reading step of axis k when the readings lie on a grid (raw counts, fixed-point
// exports): the smallest non-zero change between consecutive readings, accepted when nearly
// every reading is a whole number of steps from the first. 0 for unquantised data.
double quantisationStep(const std::vector<Vec3>& v, int k) {
  double step = 0.0;
  for (std::size_t i = 1; i < v.size(); ++i) {
    const double d = std::abs(v[i][k] - v[i - 1][k]);
    if (d > 0.0 && (step == 0.0 || d < step)) step = d;
  }
  if (step == 0.0) return 0.0;
  std::size_t on_grid = 0;
  for (const Vec3& x : v) {
    const double units = (x[k] - v.front()[k]) / step;
    if (std::abs(units - std::round(units)) < 1e-3) ++on_grid;
  }
  return on_grid >= v.size() - v.size() / 100 ? step : 0.0;
}

// The least quiet level the data can show (total over axes): the variance of their
// quantisation (q^2/12 per axis for a reading step q), and the rounding of the window sums
// (1e-12 of the largest squared deviation: far above double rounding, far below any sensor's
// noise). Noise-free or coarsely quantised statics then count as quiet, not as motion.
double quietFloor(const std::vector<Vec3>& v) {
  double floor = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double q = quantisationStep(v, k);
    floor += q * q / 12.0;
  }
  double max_dev2 = 0.0;
  for (const Vec3& x : v) max_dev2 = std::max(max_dev2, (x - v.front()).squaredNorm());
  return std::max(floor, 1e-12 * max_dev2);
}

double quietLevel(const std::vector<double>& var, double q, double floor) {
  std::vector<double> sorted = var;
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  return std::max(sorted[static_cast<std::size_t>(k)], floor);
}

}  // namespace

RecordingCheck checkRecording(const RawImuData& d, const RecordingCheckOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) return RecordingCheck::Error(RecordingStatusCode::kBadOptions, why);
  if (d.t.empty()) return RecordingCheck::Error(RecordingStatusCode::kEmpty, "no samples");
  if (d.accel.size() != d.t.size() || d.gyro.size() != d.t.size()) {
    std::ostringstream s;
    s << "time has " << d.t.size() << " samples, accel " << d.accel.size() << ", gyro "
      << d.gyro.size();
    return RecordingCheck::Error(RecordingStatusCode::kSizeMismatch, s.str());
  }
  for (std::size_t i = 0; i < d.t.size(); ++i) {
    if (!std::isfinite(d.t[i]) || !d.accel[i].allFinite() || !d.gyro[i].allFinite()) {
      return RecordingCheck::Error(RecordingStatusCode::kNonFinite,
                                   where(d, i) + ": NaN or infinite value");
    }
    if (i > 0 && !(d.t[i] > d.t[i - 1])) {
      return RecordingCheck::Error(RecordingStatusCode::kTimeNotIncreasing,
                                   where(d, i) + ": time does not increase");
    }
  }
  const double step = medianStep(d.t);
  for (std::size_t i = 1; i < d.t.size(); ++i) {
    if (d.t[i] - d.t[i - 1] > o.max_gap_factor * step) {
      std::ostringstream s;
      s << where(d, i) << ": gap of " << d.t[i] - d.t[i - 1] << " s after t = " << d.t[i - 1]
        << " s (median step " << step << " s): samples missing";
      return RecordingCheck::Error(RecordingStatusCode::kMissingSegment, s.str());
    }
  }
  auto clipped = [](const Vec3& v, const std::optional<double>& lo,
                    const std::optional<double>& hi) {
    for (int k = 0; k < 3; ++k) {
      if (lo && v[k] <= *lo) return k;
      if (hi && v[k] >= *hi) return k;
    }
    return -1;
  };
  for (std::size_t i = 0; i < d.t.size(); ++i) {
    const int ka = clipped(d.accel[i], o.accel_min, o.accel_max);
    const int kg = clipped(d.gyro[i], o.gyro_min, o.gyro_max);
    if (ka >= 0 || kg >= 0) {
      std::ostringstream s;
      s << where(d, i) << ": " << (ka >= 0 ? "accel" : "gyro") << " axis "
        << "xyz"[ka >= 0 ? ka : kg] << " at its range limit (reading "
        << (ka >= 0 ? d.accel[i][ka] : d.gyro[i][kg]) << ")";
      return RecordingCheck::Error(RecordingStatusCode::kSaturated, s.str());
    }
  }
  return RecordingCheck::Ok();
}

bool IncrementCheckOptions::IsValid(std::string* why) const {
  if (!(max_gap_factor > 1.0)) return invalidOption(why, "max_gap_factor must be > 1");
  if (gyro_range_radps && !(*gyro_range_radps > 0.0))
    return invalidOption(why, "gyro range must be > 0");
  if (accel_range_mps2 && !(*accel_range_mps2 > 0.0))
    return invalidOption(why, "accel range must be > 0");
  return true;
}

namespace {

// A gap from t_a to t_b harms the segments' use when a segment overlaps it or a rotation ends
// at (or before, with nothing between) t_a or begins at (or after) t_b.
bool gapHarms(double t_a, double t_b, std::span<const Segment> segments) {
  if (segments.empty()) return true;
  const Segment* before = nullptr;
  const Segment* after = nullptr;
  for (const Segment& s : segments) {
    if (s.t0 < t_b && s.t1 > t_a) return true;
    if (s.t1 <= t_a && (!before || s.t1 > before->t1)) before = &s;
    if (s.t0 >= t_b && (!after || s.t0 < after->t0)) after = &s;
  }
  return (before && before->kind == SegmentKind::kRotate) ||
         (after && after->kind == SegmentKind::kRotate);
}

}  // namespace

double medianSampleStep(std::span<const nav::ImuSample> samples) {
  // The steps straight from the samples (medianStep's arithmetic, without a copy of the times:
  // a recording at 2 kHz is millions of samples, and every calibration checks it).
  std::vector<double> dt;
  dt.reserve(samples.size());
  for (std::size_t i = 1; i < samples.size(); ++i) dt.push_back(samples[i].t - samples[i - 1].t);
  return median(std::move(dt));
}

RecordingCheck checkIncrements(std::span<const nav::ImuSample> imu, const IncrementCheckOptions& o,
                               const std::string& what, std::span<const Segment> segments) {
  std::string why;
  if (!o.IsValid(&why)) return RecordingCheck::Error(RecordingStatusCode::kBadOptions, why);
  if (imu.size() < 2) {
    return RecordingCheck::Error(RecordingStatusCode::kEmpty, what + ": fewer than 2 IMU samples");
  }
  auto at = [&](std::size_t i) {
    std::ostringstream s;
    s << what << ": IMU sample " << i << " (t = " << imu[i].t << " s)";
    return s.str();
  };
  for (std::size_t i = 0; i < imu.size(); ++i) {
    if (!std::isfinite(imu[i].t) || !imu[i].dtheta.allFinite() || !imu[i].dvel.allFinite()) {
      return RecordingCheck::Error(RecordingStatusCode::kNonFinite,
                                   at(i) + ": NaN or infinite value");
    }
    if (i > 0 && !(imu[i].t > imu[i - 1].t)) {
      return RecordingCheck::Error(RecordingStatusCode::kTimeNotIncreasing,
                                   at(i) + ": time does not increase");
    }
  }
  const double step = medianSampleStep(imu);
  for (std::size_t i = 1; i < imu.size(); ++i) {
    const double dt = imu[i].t - imu[i - 1].t;
    if (dt > o.max_gap_factor * step && gapHarms(imu[i - 1].t, imu[i].t, segments)) {
      std::ostringstream s;
      s << at(i) << ": gap of " << dt << " s after t = " << imu[i - 1].t << " s (median step "
        << step << " s): samples missing"
        << (segments.empty() ? "" : " inside a segment or next to a rotation");
      return RecordingCheck::Error(RecordingStatusCode::kMissingSegment, s.str());
    }
    for (int k = 0; k < 3; ++k) {
      const double rate = std::abs(imu[i].dtheta[k]) / dt;
      const double force = std::abs(imu[i].dvel[k]) / dt;
      if ((o.gyro_range_radps && rate >= *o.gyro_range_radps) ||
          (o.accel_range_mps2 && force >= *o.accel_range_mps2)) {
        const bool gyro = o.gyro_range_radps && rate >= *o.gyro_range_radps;
        std::ostringstream s;
        s << at(i) << ": " << (gyro ? "gyro" : "accel") << " axis "
          << "xyz"[k] << " at its range limit (" << (gyro ? rate : force)
          << (gyro ? " rad/s" : " m/s^2")
          << " >= " << (gyro ? *o.gyro_range_radps : *o.accel_range_mps2) << "): clipped";
        return RecordingCheck::Error(RecordingStatusCode::kSaturated, s.str());
      }
    }
  }
  return RecordingCheck::Ok();
}

StaticDetectionResult detectStaticSpans(const RawImuData& d, const StaticDetectionOptions& o) {
  StaticDetectionResult r;
  std::string why;
  if (!o.IsValid(&why)) {
    r.status = RecordingCheck::Error(RecordingStatusCode::kBadOptions, why);
    return r;
  }
  if (d.t.size() < 3 || d.accel.size() != d.t.size() ||
      (o.use_gyro && d.gyro.size() != d.t.size())) {
    r.status = RecordingCheck::Error(RecordingStatusCode::kEmpty,
                                     "fewer than 3 samples or triad sizes differ from time");
    return r;
  }
  const double step = medianStep(d.t);
  const auto half = static_cast<std::size_t>(std::max(1.0, std::round(0.5 * o.window_s / step)));
  const std::vector<double> va = windowVariance(d.accel, half);
  r.accel_quiet_variance = quietLevel(va, o.quiet_quantile, quietFloor(d.accel));
  r.accel_threshold = o.threshold_factor * r.accel_quiet_variance;
  std::vector<double> vg;
  double gyro_threshold = 0.0;
  if (o.use_gyro) {
    vg = windowVariance(d.gyro, half);
    gyro_threshold = o.threshold_factor * quietLevel(vg, o.quiet_quantile, quietFloor(d.gyro));
  }
  auto isStatic = [&](std::size_t i) {
    return va[i] <= r.accel_threshold && (!o.use_gyro || vg[i] <= gyro_threshold);
  };
  std::size_t i = 0;
  const std::size_t n = d.t.size();
  while (i < n) {
    if (!isStatic(i)) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && isStatic(j)) ++j;
    StaticSpan s{i, j, d.t[i], d.t[j - 1]};
    if (s.duration() >= o.min_duration_s) r.spans.push_back(s);
    i = j;
  }
  if (r.spans.empty()) {
    r.status = RecordingCheck::Error(
        RecordingStatusCode::kTooFewStatics,
        "no static interval of at least " + std::to_string(o.min_duration_s) + " s found");
  }
  return r;
}

Vec3 spanMean(const std::vector<Vec3>& v, const StaticSpan& span) {
  Vec3 m = Vec3::Zero();
  for (std::size_t i = span.begin; i < span.end; ++i) m += v[i];
  return span.end > span.begin ? Vec3(m / static_cast<double>(span.end - span.begin)) : m;
}

}  // namespace imubench::calib
