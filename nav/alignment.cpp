#include "nav/alignment.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace imubench::nav {

namespace {

AlignmentResult fail(AlignmentStatus status, const std::string& message) {
  AlignmentResult r;
  r.status = status;
  r.message = message;
  return r;
}

// Orthonormal triad (f, f x w, f x (f x w)), normalized columns.
Mat3 triad(const Vec3& f, const Vec3& w) {
  const Vec3 u1 = f.normalized();
  const Vec3 u2 = f.cross(w).normalized();
  const Vec3 u3 = u1.cross(u2);
  Mat3 t;
  t.col(0) = u1;
  t.col(1) = u2;
  t.col(2) = u3;
  return t;
}

}  // namespace

bool AlignmentOptions::IsValid(std::string* why) const {
  auto bad = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(min_duration_s > 0.0)) return bad("min_duration_s must be > 0");
  if (static_blocks < 2) return bad("static_blocks must be >= 2");
  if (min_samples < static_blocks) return bad("min_samples must be >= static_blocks");
  if (!(max_block_accel_dev_mps2 > 0.0)) return bad("max_block_accel_dev_mps2 must be > 0");
  if (!(max_block_rate_dev_radps > 0.0)) return bad("max_block_rate_dev_radps must be > 0");
  if (!(max_gravity_rel_error > 0.0)) return bad("max_gravity_rel_error must be > 0");
  if (!(max_rate_earth_multiple > 0.0)) return bad("max_rate_earth_multiple must be > 0");
  if (!(min_sin_f_w > 0.0 && min_sin_f_w < 1.0)) return bad("min_sin_f_w must be in (0, 1)");
  return true;
}

AlignmentResult alignFromMeans(const Vec3& f_mean_B, const Vec3& w_mean_B, double latitude_rad,
                               const AlignmentOptions& opt) {
  std::string why;
  if (!opt.IsValid(&why)) return fail(AlignmentStatus::kInvalidOptions, why);
  const double fn = f_mean_B.norm();
  const double wn = w_mean_B.norm();
  if (!(fn > 0.0) || !(wn > 0.0) || !std::isfinite(fn) || !std::isfinite(wn)) {
    return fail(AlignmentStatus::kHeadingUnobservable,
                "mean specific force or angular rate is zero or not finite");
  }
  const double sin_fw = f_mean_B.cross(w_mean_B).norm() / (fn * wn);
  if (sin_fw < opt.min_sin_f_w || std::abs(std::cos(latitude_rad)) < opt.min_sin_f_w) {
    std::ostringstream m;
    m << "heading unobservable: angle between gravity and Earth rate is "
      << std::asin(std::min(1.0, sin_fw)) * kRadToDeg << " deg (site latitude "
      << latitude_rad * kRadToDeg << " deg)";
    return fail(AlignmentStatus::kHeadingUnobservable, m.str());
  }
  const Vec3 f_L(0.0, 0.0, 1.0);  // direction of the specific force at rest: Up
  const Vec3 w_L = earthRateL(latitude_rad);
  const Mat3 T_L = triad(f_L, w_L);
  const Mat3 T_B = triad(f_mean_B, w_mean_B);

  AlignmentResult r;
  r.status = AlignmentStatus::kOk;
  r.C_LB = T_L * T_B.transpose();
  r.q_BtoL = Quat(r.C_LB).normalized();
  r.C_LB = r.q_BtoL.toRotationMatrix();
  r.f_mean_B = f_mean_B;
  r.w_mean_B = w_mean_B;
  return r;
}

AlignmentResult coarseAlign(std::span<const ImuSample> samples, const Site& site,
                            const AlignmentOptions& opt) {
  std::string why;
  if (!opt.IsValid(&why)) return fail(AlignmentStatus::kInvalidOptions, why);
  const std::size_t n = samples.size();
  if (n < static_cast<std::size_t>(opt.min_samples) || n < 2) {
    std::ostringstream m;
    m << "span has " << n << " samples, alignment needs at least " << opt.min_samples;
    return fail(AlignmentStatus::kTooShort, m.str());
  }
  for (std::size_t i = 1; i < n; ++i) {
    if (!(samples[i].t > samples[i - 1].t)) {
      std::ostringstream m;
      m << "time stamps not increasing at sample " << i << " (t = " << samples[i].t << " s after "
        << samples[i - 1].t << " s)";
      return fail(AlignmentStatus::kBadTimestamps, m.str());
    }
  }
  const double t_begin = samples[0].t - (samples[1].t - samples[0].t);
  const double duration = samples[n - 1].t - t_begin;
  if (duration < opt.min_duration_s) {
    std::ostringstream m;
    m << "span lasts " << duration << " s, alignment needs at least " << opt.min_duration_s << " s";
    return fail(AlignmentStatus::kTooShort, m.str());
  }

  // Block sums of increments -> block mean specific force / rate.
  const std::size_t blocks = static_cast<std::size_t>(opt.static_blocks);
  Vec3 sum_dv = Vec3::Zero();
  Vec3 sum_dth = Vec3::Zero();
  std::vector<Vec3> block_f(blocks), block_w(blocks);
  std::vector<double> block_t0(blocks), block_t1(blocks);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t i0 = b * n / blocks;
    const std::size_t i1 = (b + 1) * n / blocks;
    Vec3 dv = Vec3::Zero();
    Vec3 dth = Vec3::Zero();
    for (std::size_t i = i0; i < i1; ++i) {
      dv += samples[i].dvel;
      dth += samples[i].dtheta;
    }
    const double t0 = i0 == 0 ? t_begin : samples[i0 - 1].t;
    const double t1 = samples[i1 - 1].t;
    block_f[b] = dv / (t1 - t0);
    block_w[b] = dth / (t1 - t0);
    block_t0[b] = t0;
    block_t1[b] = t1;
    sum_dv += dv;
    sum_dth += dth;
  }
  const Vec3 f_mean = sum_dv / duration;
  const Vec3 w_mean = sum_dth / duration;
  if (!f_mean.allFinite() || !w_mean.allFinite()) {
    return fail(AlignmentStatus::kNotStatic, "increments contain non-finite values");
  }
  for (std::size_t b = 0; b < blocks; ++b) {
    const double df = (block_f[b] - f_mean).norm();
    const double dw = (block_w[b] - w_mean).norm();
    if (df > opt.max_block_accel_dev_mps2 || dw > opt.max_block_rate_dev_radps) {
      std::ostringstream m;
      m << "not static: over [" << block_t0[b] << ", " << block_t1[b]
        << "] s the mean specific force differs from the span mean by " << df << " m/s^2 (limit "
        << opt.max_block_accel_dev_mps2 << ") and the mean rate by " << dw * kRadToDeg
        << " deg/s (limit " << opt.max_block_rate_dev_radps * kRadToDeg << ")";
      return fail(AlignmentStatus::kNotStatic, m.str());
    }
  }
  const double g = siteGravity(site);
  if (std::abs(f_mean.norm() - g) > opt.max_gravity_rel_error * g) {
    std::ostringstream m;
    m << "mean specific force " << f_mean.norm() << " m/s^2 differs from site gravity " << g
      << " m/s^2 by more than " << opt.max_gravity_rel_error * 100.0 << " %";
    return fail(AlignmentStatus::kGravityMismatch, m.str());
  }
  if (w_mean.norm() > opt.max_rate_earth_multiple * kEarthRate) {
    std::ostringstream m;
    m << "mean angular rate " << w_mean.norm() / kDegPerHourToRadPerSec << " deg/h exceeds "
      << opt.max_rate_earth_multiple
      << " x Earth rate: the IMU is rotating (or its gyro bias is gross)";
    return fail(AlignmentStatus::kRateTooLarge, m.str());
  }
  AlignmentResult r = alignFromMeans(f_mean, w_mean, site.latitude_rad, opt);
  r.f_mean_B = f_mean;
  r.w_mean_B = w_mean;
  r.duration_s = duration;
  return r;
}

Vec3 rollPitchHeading(const Quat& q_BtoL) {
  const Mat3 c = q_BtoL.normalized().toRotationMatrix();
  const double heading = std::atan2(c(0, 1), c(1, 1));
  const double pitch = std::atan2(c(2, 1), std::hypot(c(0, 1), c(1, 1)));
  const double roll = std::atan2(-c(2, 0), c(2, 2));
  return {roll, pitch, heading};
}

}  // namespace imubench::nav
