#include "calib/segment_check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "calib/option_check.h"

namespace imubench::calib {

bool SegmentCheckOptions::IsValid(std::string* why) const {
  if (!(adjacency_s >= 0.0)) return invalidOption(why, "adjacency_s must be >= 0");
  if (!(same_angle_rad > 0.0)) return invalidOption(why, "same_angle_rad must be > 0");
  if (!(still_span_rad > 0.0)) return invalidOption(why, "still_span_rad must be > 0");
  return true;
}

namespace {

double axisOf(const TableAngles& a, int axis) {
  return axis == 0 ? a.outer : (axis == 1 ? a.middle : a.inner);
}

// Encoder angles over [t0, t1]: mean and span per axis (unwrapped against the first sample, so
// a hold at the encoder's wrap reads one angle).
struct AngleStats {
  int samples = 0;
  std::array<double, 3> mean{};
  std::array<double, 3> span{};
};

AngleStats anglesOver(std::span<const TableSample> table, double t0, double t1) {
  AngleStats s;
  auto it = std::lower_bound(table.begin(), table.end(), t0,
                             [](const TableSample& x, double t) { return x.t < t; });
  std::array<double, 3> ref{}, lo{}, hi{};
  for (; it != table.end() && it->t <= t1; ++it) {
    for (int a = 0; a < 3; ++a) {
      const std::size_t k = static_cast<std::size_t>(a);
      if (s.samples == 0) ref[k] = axisOf(it->angles, a);
      const double d = std::remainder(axisOf(it->angles, a) - ref[k], 2.0 * kPi);
      s.mean[k] += d;
      lo[k] = s.samples == 0 ? d : std::min(lo[k], d);
      hi[k] = s.samples == 0 ? d : std::max(hi[k], d);
    }
    ++s.samples;
  }
  for (std::size_t k = 0; k < 3; ++k) {
    if (s.samples > 0) s.mean[k] = ref[k] + s.mean[k] / s.samples;
    s.span[k] = hi[k] - lo[k];
  }
  return s;
}

double largestSpan(const AngleStats& s, TableKind kind) {
  double m = 0.0;
  for (int a = 0; a < axisCount(kind); ++a) {
    // axisCount order (outer, [middle,] inner) mapped onto (outer, middle, inner)
    const int axis = (kind == TableKind::kTwoAxis && a == 1) ? 2 : a;
    m = std::max(m, s.span[static_cast<std::size_t>(axis)]);
  }
  return m;
}

bool sameAngles(const AngleStats& a, const AngleStats& b, double tol) {
  if (a.samples == 0 || b.samples == 0) return true;  // no encoder sample: nothing contradicts
  for (std::size_t k = 0; k < 3; ++k) {
    if (std::abs(std::remainder(a.mean[k] - b.mean[k], 2.0 * kPi)) > tol) return false;
  }
  return true;
}

std::string where(const Segment& s) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), " (%.3f-%.3f s)", s.t0, s.t1);
  return "'" + s.label + "'" + buf;
}

}  // namespace

SegmentCheckResult checkSegments(TableKind kind, std::span<const TableSample> table,
                                 std::span<const Segment> segments, const SegmentCheckOptions& o) {
  SegmentCheckResult r;
  AngleStats last_static;
  for (const Segment& seg : segments) {
    if (seg.kind == SegmentKind::kRotate) {
      const AngleStats s = anglesOver(table, seg.t0, seg.t1);
      if (s.samples >= 2 && largestSpan(s, kind) < o.still_span_rad) {
        r.contradictions.push_back("rotate segment " + where(seg) +
                                   ": the encoders show no axis turning in it");
      }
    }
    if (seg.kind != SegmentKind::kStatic || !seg.recording) {
      r.segments.push_back(seg);
      continue;
    }
    const AngleStats s = anglesOver(table, seg.t0, seg.t1);
    if (largestSpan(s, kind) > o.still_span_rad) {
      char buf[96];
      std::snprintf(buf, sizeof(buf), ": the encoders move by %.4f deg in it, not used",
                    largestSpan(s, kind) / kDegToRad);
      r.contradictions.push_back("static segment " + where(seg) + buf);
      continue;
    }
    Segment* prev = r.segments.empty() ? nullptr : &r.segments.back();
    if (prev && prev->kind == SegmentKind::kStatic && prev->recording &&
        seg.t0 - prev->t1 <= o.adjacency_s && seg.t0 >= prev->t0 &&
        sameAngles(last_static, s, o.same_angle_rad)) {
      prev->t1 = std::max(prev->t1, seg.t1);
      prev->label += "+" + seg.label;
      last_static = anglesOver(table, prev->t0, prev->t1);
      ++r.merged;
      continue;
    }
    r.segments.push_back(seg);
    last_static = s;
  }
  if (r.merged > 0) {
    r.notes.push_back(std::to_string(r.merged) +
                      " static segments joined the adjacent hold at the same table angles "
                      "(a hold split into settle + hold is one hold)");
  }
  for (const std::string& c : r.contradictions)
    r.notes.push_back(
        "segments.csv contradicts "
        "the encoders: " +
        c);
  return r;
}

}  // namespace imubench::calib
