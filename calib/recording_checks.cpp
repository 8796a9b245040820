#include "calib/recording_checks.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <utility>

#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/rotation.h"

namespace imubench::calib {
namespace {

// Radix keys of doubles: unsigned integers in the doubles' order (negative values' bits
// inverted, the sign bit set on the others), so -0.0 sorts before +0.0 (their difference is 0).
std::uint64_t orderedKey(double d) {
  const auto u = std::bit_cast<std::uint64_t>(d);
  return (u >> 63) != 0 ? ~u : u | (std::uint64_t{1} << 63);
}

double fromOrderedKey(std::uint64_t k) {
  return std::bit_cast<double>((k >> 63) != 0 ? k & ~(std::uint64_t{1} << 63) : ~k);
}

// Sorts finite doubles ascending: an LSD radix sort over the keys' bytes, skipping the bytes
// every key shares (the sign and exponent of one channel's readings). countDistinct runs over
// every static hold of every channel of a recording (about 12 M values at 2 kHz), where
// std::sort took about a second.
void sortDoubles(std::vector<double>* values) {
  constexpr std::size_t kBytes = 8;
  constexpr std::size_t kBuckets = 256;
  const std::size_t n = values->size();
  if (n < 2) return;
  std::vector<std::uint64_t> keys(n), scratch(n);
  std::vector<std::array<std::size_t, kBuckets>> counts(kBytes);
  for (auto& c : counts) c.fill(0);
  for (std::size_t i = 0; i < n; ++i) {
    keys[i] = orderedKey((*values)[i]);
    for (std::size_t b = 0; b < kBytes; ++b) ++counts[b][(keys[i] >> (8 * b)) & 0xff];
  }
  for (std::size_t b = 0; b < kBytes; ++b) {
    auto& c = counts[b];
    if (std::find(c.begin(), c.end(), n) != c.end()) continue;  // every key shares this byte
    std::size_t offset = 0;
    for (std::size_t& x : c) offset += std::exchange(x, offset);
    for (const std::uint64_t k : keys) scratch[c[(k >> (8 * b)) & 0xff]++] = k;
    keys.swap(scratch);
  }
  for (std::size_t i = 0; i < n; ++i) (*values)[i] = fromOrderedKey(keys[i]);
}

// Accumulates attitudes and rotation increments into a MotionSupport.
class SupportBuilder {
 public:
  explicit SupportBuilder(const MotionSupportOptions& o) : o_(o) {}

  // A gravity direction the motion passes through (the navigation-based method sees the
  // accelerometers along it): widens the spans, not a hold.
  void addSwept(const Vec3& up_B) {
    if (!(up_B.norm() > 0.0) || !up_B.allFinite()) return;
    const Vec3 u = up_B.normalized();
    lo_ = lo_.cwiseMin(u);
    hi_ = hi_.cwiseMax(u);
  }

  void addHold(const Vec3& up_B) {
    if (!(up_B.norm() > 0.0) || !up_B.allFinite()) return;
    const Vec3 u = up_B.normalized();
    addSwept(u);
    const double cos_same = std::cos(o_.same_attitude_deg / kRadToDeg);
    for (const Vec3& a : s_.attitudes) {
      if (a.dot(u) >= cos_same) return;
    }
    s_.attitudes.push_back(u);
  }

  // A body-frame rotation increment (rotation vector, rad).
  void addRotation(const Vec3& rv) {
    const double angle = rv.norm();
    if (!(angle > 0.0) || !rv.allFinite()) return;
    s_.rotation_rad += rv.cwiseAbs();
    const Vec3 axis = rv / angle;
    const double cos_same = std::cos(o_.same_axis_deg / kRadToDeg);
    for (std::size_t k = 0; k < axes_.size(); ++k) {
      if (std::abs(axes_[k].dot(axis)) >= cos_same) {
        turned_[k] += angle;
        return;
      }
    }
    axes_.push_back(axis);
    turned_.push_back(angle);
  }

  MotionSupport finish(std::string source) {
    s_.source = std::move(source);
    for (int k = 0; k < 3; ++k) {
      s_.gravity_span(k) = std::max(0.0, hi_(k) - lo_(k));
      s_.accel_axis[static_cast<std::size_t>(k)] = s_.gravity_span(k) >= o_.min_gravity_span;
      s_.gyro_axis[static_cast<std::size_t>(k)] = s_.rotation_rad(k) >= o_.min_rotation_rad;
    }
    s_.rotation_axes = static_cast<int>(std::count_if(
        turned_.begin(), turned_.end(), [this](double a) { return a >= o_.min_rotation_rad; }));
    return s_;
  }

 private:
  MotionSupportOptions o_;
  MotionSupport s_;
  std::vector<Vec3> axes_;
  std::vector<double> turned_;
  Vec3 lo_ = Vec3::Constant(1.0), hi_ = Vec3::Constant(-1.0);  // up-component range
};

Vec3 rotationVector(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// The table sample nearest time t (table non-empty, t increasing).
const TableSample& tableAt(std::span<const TableSample> table, double t) {
  const auto it = std::lower_bound(table.begin(), table.end(), t,
                                   [](const TableSample& s, double x) { return s.t < x; });
  if (it == table.end()) return table.back();
  if (it == table.begin()) return *it;
  return (it->t - t) < (t - std::prev(it)->t) ? *it : *std::prev(it);
}

MotionSupport supportFromTable(const RecordingView& rec, const MotionSupportOptions& o) {
  SupportBuilder b(o);
  const TableModel table(rec.geometry, TableErrors{});
  for (const Segment& s : rec.segments) {
    if (s.kind != SegmentKind::kStatic) continue;
    const Mat3 C = table.nominalC_LB(tableAt(rec.table, 0.5 * (s.t0 + s.t1)).angles);
    b.addHold(C.transpose() * Vec3::UnitZ());
  }
  Mat3 prev = table.nominalC_LB(rec.table.front().angles);
  for (std::size_t k = 1; k < rec.table.size(); ++k) {
    const Mat3 C = table.nominalC_LB(rec.table[k].angles);
    b.addRotation(rotationVector(prev.transpose() * C));
    b.addSwept(C.transpose() * Vec3::UnitZ());
    prev = C;
  }
  return b.finish("table angles");
}

MotionSupport supportFromImu(const RecordingView& rec, const MotionSupportOptions& o) {
  SupportBuilder b(o);
  for (const Segment& s : rec.segments) {
    if (s.kind != SegmentKind::kStatic) continue;
    Vec3 dv = Vec3::Zero();
    for (const nav::ImuSample& x : rec.imu) {
      if (x.t > s.t0 && x.t <= s.t1) dv += x.dvel;
    }
    b.addHold(dv);
  }
  for (std::size_t i = 1; i < rec.imu.size(); ++i) {
    const double dt = rec.imu[i].t - rec.imu[i - 1].t;
    if (rec.imu[i].dtheta.norm() > o.moving_rate_radps * dt) b.addRotation(rec.imu[i].dtheta);
  }
  return b.finish("IMU readings");
}

std::string axesList(const std::array<bool, 3>& ok) {
  std::string s;
  for (int k = 0; k < 3; ++k) {
    if (!ok[static_cast<std::size_t>(k)]) s += std::string(s.empty() ? "" : ", ") + "xyz"[k];
  }
  return s;
}

}  // namespace

bool MotionSupport::determinesTriads() const {
  return std::all_of(accel_axis.begin(), accel_axis.end(), [](bool b) { return b; }) &&
         std::all_of(gyro_axis.begin(), gyro_axis.end(), [](bool b) { return b; });
}

std::string MotionSupport::describe() const {
  char buf[400];
  std::snprintf(buf, sizeof(buf),
                "%zu distinct attitude(s) (gravity directions in the body frame; up-component "
                "spans x %.2f, y %.2f, z %.2f of 2), rotation about x %.0f deg, y %.0f deg, z "
                "%.0f deg (%d distinct rotation axes), from the %s",
                attitudes.size(), gravity_span.x(), gravity_span.y(), gravity_span.z(),
                rotation_rad.x() * kRadToDeg, rotation_rad.y() * kRadToDeg,
                rotation_rad.z() * kRadToDeg, rotation_axes, source.c_str());
  return buf;
}

std::string MotionSupport::missing() const {
  std::string m;
  if (const std::string a = axesList(accel_axis); !a.empty()) {
    m += "accelerometer scale and bias of axis " + a +
         " not separable (gravity never along them both ways)";
  }
  if (const std::string g = axesList(gyro_axis); !g.empty()) {
    m += std::string(m.empty() ? "" : "; ") + "gyro scale of axis " + g +
         " not excited (no rotation about it)";
  }
  return m;
}

MotionSupport motionSupport(const RecordingView& rec, const MotionSupportOptions& o) {
  if (rec.table.size() >= 2) return supportFromTable(rec, o);
  return supportFromImu(rec, o);
}

MotionSupport motionSupport(const RawImuData& d, std::span<const StaticSpan> spans,
                            const MotionSupportOptions& o) {
  SupportBuilder b(o);
  for (const StaticSpan& s : spans) b.addHold(spanMean(d.accel, s));
  for (std::size_t i = 1; i < d.size() && i < d.gyro.size(); ++i) {
    const double dt = d.t[i] - d.t[i - 1];
    if (d.gyro[i].norm() > o.moving_rate_radps) b.addRotation(d.gyro[i] * dt);
  }
  return b.finish("IMU readings");
}

namespace {

RateConsistency judged(double factor, std::string evidence, const std::string& what_to_check,
                       const RateCheckOptions& o) {
  RateConsistency r;
  r.judged = true;
  r.factor = factor;
  r.evidence = std::move(evidence);
  if (!(factor >= o.min_factor && factor <= o.max_factor)) {
    char buf[120];
    std::snprintf(buf, sizeof(buf), " is %.3g times what it should be (consistent: %.2f..%.2f)",
                  factor, o.min_factor, o.max_factor);
    r.status = Status::Error(r.evidence + buf + ": " + what_to_check);
  }
  return r;
}

// Static gyro norm against the Earth rate over holds at three or more distinct attitudes whose
// norms agree (the bias far below the Earth rate); not judged otherwise.
RateConsistency earthRateCheck(const RecordingView& rec, const RateCheckOptions& o) {
  std::vector<double> norms;
  SupportBuilder attitudes({});
  for (const Segment& s : rec.segments) {
    if (s.kind != SegmentKind::kStatic || s.t1 - s.t0 < o.min_hold_s) continue;
    Vec3 dth = Vec3::Zero(), dv = Vec3::Zero();
    double T = 0.0, t_prev = NAN;
    for (const nav::ImuSample& x : rec.imu) {
      if (x.t > s.t0 && x.t <= s.t1 && std::isfinite(t_prev)) {
        dth += x.dtheta;
        dv += x.dvel;
        T += x.t - t_prev;
      }
      t_prev = x.t;
    }
    if (!(T > 0.0)) continue;
    norms.push_back(dth.norm() / T);
    attitudes.addHold(dv);
  }
  const MotionSupport s = attitudes.finish("");
  if (s.attitudes.size() < 3) return {};
  const auto [lo, hi] = std::minmax_element(norms.begin(), norms.end());
  if (*hi - *lo > o.earth_rate_agreement * nav::kEarthRate) return {};
  std::sort(norms.begin(), norms.end());
  const double median = norms[norms.size() / 2];
  return judged(median / nav::kEarthRate,
                "the static gyro rate (" + std::to_string(median) +
                    " rad/s, the same in every hold) against the Earth rate",
                "the recording's time stamps or gyro unit are wrong", o);
}

}  // namespace

RateConsistency checkRateConsistency(const RecordingView& rec, const RateCheckOptions& o) {
  double gyro = 0.0, table = 0.0;
  if (rec.table.size() >= 2) {
    const TableModel model(rec.geometry, TableErrors{});
    for (const Segment& s : rec.segments) {
      if (s.kind != SegmentKind::kRotate) continue;
      double seg_table = 0.0, seg_gyro = 0.0;
      const TableSample* prev = nullptr;
      for (const TableSample& x : rec.table) {
        if (x.t < s.t0 || x.t > s.t1) continue;
        if (prev) {
          seg_table += Eigen::AngleAxisd(model.nominalC_LB(prev->angles).transpose() *
                                         model.nominalC_LB(x.angles))
                           .angle();
        }
        prev = &x;
      }
      if (!prev) continue;
      const double t_first = tableAt(rec.table, s.t0).t, t_last = prev->t;
      for (const nav::ImuSample& x : rec.imu) {
        if (x.t > t_first && x.t <= t_last) seg_gyro += x.dtheta.norm();
      }
      if (seg_table < 0.5) continue;  // too little turn to compare
      table += seg_table;
      gyro += seg_gyro;
    }
  }
  if (table > 0.0) {
    return judged(gyro / table,
                  "the gyro's integrated rotation over the rotate segments (" +
                      std::to_string(gyro * kRadToDeg) + " deg) against the table's (" +
                      std::to_string(table * kRadToDeg) + " deg)",
                  "the recording's time stamps or gyro unit are wrong", o);
  }
  return earthRateCheck(rec, o);
}

RateConsistency checkRateConsistency(const TriadModel& gyro, double nominal,
                                     const std::string& rate_option, const RateCheckOptions& o) {
  double worst = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double f = std::abs(gyro.scale(k)) / nominal;
    if (std::abs(std::log(f)) > std::abs(std::log(worst))) worst = f;
  }
  char buf[200];
  std::snprintf(buf, sizeof(buf),
                "the gyro scales of the calibration (%.4g, %.4g, %.4g readings per rad/s, "
                "nominal %.4g for the reading unit): the largest",
                gyro.scale.x(), gyro.scale.y(), gyro.scale.z(), nominal);
  char fix[240];
  std::snprintf(fix, sizeof(fix),
                "the time axis is off by that factor: %s is probably not the recording's "
                "sampling rate (the data suggest %.4g times it)",
                rate_option.c_str(), worst);
  return judged(worst, buf, fix, o);
}

int countDistinct(std::vector<double> v, double tolerance) {
  sortDoubles(&v);
  int n = v.empty() ? 0 : 1;
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (v[i] - v[i - 1] > tolerance) ++n;
  }
  return n;
}

std::optional<double> gyroReadingsPerRadps(const std::string& unit) {
  if (unit == "rad/s") return 1.0;
  if (unit == "deg/s") return kRadToDeg;
  return std::nullopt;
}

RecordingCheck checkCalibratedRanges(const RawImuData& d, const TriadModel& accel,
                                     const TriadModel& gyro, const RangeCheckOptions& o) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    for (int triad = 0; triad < 2; ++triad) {
      const std::optional<double>& range = triad == 0 ? o.accel_range_mps2 : o.gyro_range_radps;
      if (!range) continue;
      const Vec3 in = triad == 0 ? accel.input(d.accel[i]) : gyro.input(d.gyro[i]);
      for (int k = 0; k < 3; ++k) {
        if (std::abs(in(k)) < *range) continue;
        const double unit = triad == 0 ? 9.80665 : 1.0 / kRadToDeg;
        char buf[240];
        std::snprintf(buf, sizeof(buf),
                      "sample %zu (t = %.3f s): %s axis %c reaches %.4g %s, at or beyond the "
                      "IMU's range %.4g %s: clipped",
                      i, d.t[i], triad == 0 ? "accel" : "gyro", "xyz"[k], std::abs(in(k)) / unit,
                      triad == 0 ? "g" : "deg/s", *range / unit, triad == 0 ? "g" : "deg/s");
        return RecordingCheck::Error(RecordingStatusCode::kSaturated, buf);
      }
    }
  }
  return RecordingCheck::Ok();
}

}  // namespace imubench::calib
