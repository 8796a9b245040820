#include "nav/inertial_alignment.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace imubench::nav {
namespace {

using Mat4 = Eigen::Matrix4d;
using Vec4 = Eigen::Vector4d;

InertialAlignmentResult fail(AlignmentStatus status, const std::string& message) {
  InertialAlignmentResult r;
  r.status = status;
  r.message = message;
  return r;
}

// One block: the mean specific force in b0 and its mid-time since the span's start.
struct Block {
  Vec3 u_b0 = Vec3::Zero();
  double t_s = 0.0;
};

// Where gravity's reaction (0, 0, g) of the L frame at time t points in n0: turned with the
// Earth about its axis e_L = (0, cos lat, sin lat) by W t.
Vec3 gravityInN0(double t_s, double latitude_rad, double g) {
  const Vec3 e(0.0, std::cos(latitude_rad), std::sin(latitude_rad));
  return Eigen::AngleAxisd(kEarthRate * t_s, e) * Vec3(0.0, 0.0, g);
}

// The gyro-tracked attitude against b0 and the block means of the specific force in b0.
struct Tracked {
  std::vector<Block> blocks;
  Quat q_b_to_b0 = Quat::Identity();  // at the span's end
  double sway_peak_rad = 0.0;
};

Tracked track(std::span<const ImuSample> s, double t0, int n_blocks) {
  Tracked out;
  const double span = s.back().t - t0;
  std::vector<Vec3> dv_sum(static_cast<std::size_t>(n_blocks), Vec3::Zero());
  std::vector<double> dt_sum(dv_sum.size(), 0.0), t_sum(dv_sum.size(), 0.0);
  Quat q = Quat::Identity();
  double t_prev = t0;
  for (const ImuSample& x : s) {
    const double dt = x.t - t_prev;
    const Quat q_mid = q * quatFromRotationVector(0.5 * x.dtheta);
    q = (q * quatFromRotationVector(x.dtheta)).normalized();
    out.sway_peak_rad =
        std::max(out.sway_peak_rad, 2.0 * std::acos(std::min(1.0, std::abs(q.w()))));
    const auto k = static_cast<std::size_t>(
        std::clamp(static_cast<int>((x.t - 0.5 * dt - t0) / span * n_blocks), 0, n_blocks - 1));
    dv_sum[k] += q_mid * x.dvel;
    dt_sum[k] += dt;
    t_sum[k] += dt * (x.t - 0.5 * dt - t0);
    t_prev = x.t;
  }
  for (std::size_t k = 0; k < dv_sum.size(); ++k) {
    if (dt_sum[k] > 0.0) out.blocks.push_back({dv_sum[k] / dt_sum[k], t_sum[k] / dt_sum[k]});
  }
  out.q_b_to_b0 = q;
  return out;
}

// Wahba's problem: the rotation C (b0 <- n0) minimising sum |u_k - C a_k|^2.
Mat3 wahba(const std::vector<Block>& blocks, double latitude_rad, double g) {
  Mat3 B = Mat3::Zero();
  for (const Block& b : blocks) B += b.u_b0 * gravityInN0(b.t_s, latitude_rad, g).transpose();
  Eigen::JacobiSVD<Mat3> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double d = (svd.matrixU() * svd.matrixV().transpose()).determinant() > 0.0 ? 1.0 : -1.0;
  return svd.matrixU() * Eigen::DiagonalMatrix<double, 3>(1.0, 1.0, d) * svd.matrixV().transpose();
}

// Weighted Gauss-Newton on (rotation in n0, latitude): C = C_hat exp([phi x]); free_latitude
// false holds the latitude (3 parameters). The residuals are weighted per axis of n0 (East,
// North, Up: a ship's heave disturbs Up far more than the horizontal axes, which carry the
// heading) by weight_n0 (inverse variances; then the covariance (J^T W J)^-1 is the estimate's).
// ss_n0: the residual sums of squares per n0 axis.
struct Fit {
  Mat3 C_b0_n0 = Mat3::Identity();
  double latitude_rad = 0.0;
  Mat4 covariance = Mat4::Zero();
  Vec3 ss_n0 = Vec3::Zero();
  bool determined = false;
};

Fit gaussNewton(const std::vector<Block>& blocks, Fit fit, double g, bool free_latitude,
                int iterations, const Vec3& weight_n0) {
  const int n = free_latitude ? 4 : 3;
  for (int it = 0; it <= iterations; ++it) {
    Mat4 JtJ = Mat4::Zero();
    Vec4 Jtr = Vec4::Zero();
    fit.ss_n0 = Vec3::Zero();
    const Mat3 C_n0_b0 = fit.C_b0_n0.transpose();
    for (const Block& b : blocks) {
      const Vec3 a = gravityInN0(b.t_s, fit.latitude_rad, g);
      const Vec3 r = C_n0_b0 * (b.u_b0 - fit.C_b0_n0 * a);  // residual resolved in n0
      Eigen::Matrix<double, 3, 4> J = Eigen::Matrix<double, 3, 4>::Zero();
      J.leftCols<3>() = -skew(a);  // d(C exp([phi x]) a)/dphi = -C [a x], resolved in n0
      constexpr double kH = 1e-6;
      J.col(3) = (gravityInN0(b.t_s, fit.latitude_rad + kH, g) - a) / kH;
      JtJ += J.transpose() * weight_n0.asDiagonal() * J;
      Jtr += J.transpose() * weight_n0.asDiagonal() * r;
      fit.ss_n0 += r.cwiseProduct(r);
    }
    const Eigen::MatrixXd N = JtJ.topLeftCorner(n, n);
    Eigen::FullPivLU<Eigen::MatrixXd> lu(N);
    fit.determined = lu.rank() == n;
    if (!fit.determined) return fit;
    fit.covariance = Mat4::Zero();
    fit.covariance.topLeftCorner(n, n) = lu.inverse();
    if (it == iterations) break;
    const Eigen::VectorXd dx = lu.solve(Jtr.head(n));
    fit.C_b0_n0 = fit.C_b0_n0 * quatFromRotationVector(dx.head<3>()).toRotationMatrix();
    if (free_latitude) fit.latitude_rad += dx(3);
  }
  return fit;
}

// The fit, then refitted with the per-axis residual variances it leaves as weights (their
// degrees of freedom: blocks less a third of the parameters per axis), so the covariance is
// the estimate's own.
Fit weightedFit(const std::vector<Block>& blocks, Fit start, double g, bool free_latitude,
                int iterations) {
  const Fit first = gaussNewton(blocks, start, g, free_latitude, iterations, Vec3::Ones());
  if (!first.determined) return first;
  const double dof = static_cast<double>(blocks.size()) - (free_latitude ? 4.0 : 3.0) / 3.0;
  Vec3 w;
  for (int i = 0; i < 3; ++i) w(i) = 1.0 / std::max(first.ss_n0(i) / dof, 1e-30);
  return gaussNewton(blocks, first, g, free_latitude, iterations, w);
}

}  // namespace

bool InertialAlignmentOptions::IsValid(std::string* why) const {
  auto bad = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (blocks < 4) return bad("blocks must be >= 4");
  if (!(min_duration_s > 0.0)) return bad("min_duration_s must be > 0");
  if (!(max_residual_rad > 0.0)) return bad("max_residual_rad must be > 0");
  if (iterations < 1) return bad("iterations must be >= 1");
  if (!(min_cos_latitude > 0.0 && min_cos_latitude < 1.0))
    return bad("min_cos_latitude must be in (0, 1)");
  return true;
}

InertialAlignmentResult inertialAlign(std::span<const ImuSample> s, const Site& site,
                                      const InertialAlignmentOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) return fail(AlignmentStatus::kInvalidOptions, why);
  if (s.size() < static_cast<std::size_t>(2 * o.blocks))
    return fail(AlignmentStatus::kTooShort, "fewer than two samples per block");
  for (std::size_t i = 1; i < s.size(); ++i)
    if (!(s[i].t > s[i - 1].t))
      return fail(AlignmentStatus::kBadTimestamps, "time stamps not increasing");
  const double t0 = s[0].t - (s[1].t - s[0].t);
  const double duration = s.back().t - t0;
  char buf[400];
  if (duration < o.min_duration_s) {
    std::snprintf(buf, sizeof buf,
                  "span %.3g s shorter than %.3g s (a block must hold sway "
                  "periods)",
                  duration, o.min_duration_s);
    return fail(AlignmentStatus::kTooShort, buf);
  }
  if (std::abs(std::cos(site.latitude_rad)) < o.min_cos_latitude)
    return fail(AlignmentStatus::kHeadingUnobservable,
                "near the pole gravity turns about itself: no heading");
  const double g = siteGravity(site);
  const Tracked tr = track(s, t0, o.blocks);
  if (tr.blocks.size() < 4) return fail(AlignmentStatus::kTooShort, "fewer than 4 blocks");
  InertialAlignmentResult r;
  r.duration_s = duration;
  r.samples = static_cast<int>(s.size());
  r.blocks = static_cast<int>(tr.blocks.size());
  r.sway_peak_rad = tr.sway_peak_rad;
  const Block &first = tr.blocks.front(), &last = tr.blocks.back();
  const double cos_turn =
      std::clamp(first.u_b0.normalized().dot(last.u_b0.normalized()), -1.0, 1.0);
  r.gravity_turn_rate_radps = std::acos(cos_turn) / (last.t_s - first.t_s);
  double norm_sum = 0.0;
  for (const Block& b : tr.blocks) norm_sum += b.u_b0.norm();
  r.accel_bias_up_mps2 = norm_sum / static_cast<double>(tr.blocks.size()) - g;

  Fit fit;
  fit.latitude_rad = site.latitude_rad;
  fit.C_b0_n0 = wahba(tr.blocks, site.latitude_rad, g);
  fit = weightedFit(tr.blocks, fit, g, false, o.iterations);
  r.residual_rms_rad = std::sqrt(fit.ss_n0.sum() / static_cast<double>(tr.blocks.size())) / g;
  const double earth_turn = kEarthRate * std::abs(std::cos(site.latitude_rad));
  if (!fit.determined || r.residual_rms_rad > o.max_residual_rad) {
    std::snprintf(
        buf, sizeof buf,
        "gravity in the gyros' inertial frame does not follow the Earth's turn: RMS "
        "misfit %.3g deg (limit %.3g deg); it turned at %.3g deg/h where the Earth "
        "turns it at %.3g deg/h (%s)",
        r.residual_rms_rad * kRadToDeg, o.max_residual_rad * kRadToDeg,
        r.gravity_turn_rate_radps * kRadToDeg * 3600.0, earth_turn * kRadToDeg * 3600.0,
        r.gravity_turn_rate_radps > 3.0 * earth_turn
            ? "a gyro bias far above the Earth rate, or a rotation that is not a sway: no heading"
            : "the IMU translates, not only sways");
    return fail(r.gravity_turn_rate_radps > 3.0 * earth_turn ? AlignmentStatus::kRateTooLarge
                                                             : AlignmentStatus::kNotStatic,
                buf);
  }
  r.sigma_tilt_rad = std::sqrt(std::max(fit.covariance(0, 0), fit.covariance(1, 1)));
  r.sigma_heading_rad = std::sqrt(fit.covariance(2, 2));
  r.heading_rad_per_gyro_bias = 1.0 / earth_turn;
  const Mat3 C_LB_start = fit.C_b0_n0.transpose();
  r.q_BtoL_start = Quat(C_LB_start).normalized();
  const Mat3 C_n0_L_end =
      Eigen::AngleAxisd(kEarthRate * duration,
                        Vec3(0.0, std::cos(site.latitude_rad), std::sin(site.latitude_rad)))
          .toRotationMatrix();
  r.q_BtoL_end =
      Quat(C_n0_L_end.transpose() * C_LB_start * tr.q_b_to_b0.toRotationMatrix()).normalized();
  const Fit lat_fit = weightedFit(tr.blocks, fit, g, true, o.iterations);
  r.implied_latitude_rad = lat_fit.determined ? lat_fit.latitude_rad : std::nan("");
  r.sigma_implied_latitude_rad =
      lat_fit.determined ? std::sqrt(lat_fit.covariance(3, 3)) : std::nan("");
  r.status = AlignmentStatus::kOk;
  return r;
}

}  // namespace imubench::nav
