#include "nav/inertial_alignment.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "nav/alignment_uncertainty.h"

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

// One block: the (weighted) mean specific force in b0 and its time since the span's start.
struct Block {
  Vec3 u_b0 = Vec3::Zero();
  double t_s = 0.0;
};

// Cells per window (nav/alignment_uncertainty.h: a block weighs its two windows' cells by a
// triangle): 8 make the triangle's steps an eighth of it.
constexpr int kCellsPerWindow = 8;

// Where gravity's reaction (0, 0, g) of the L frame at time t points in n0: turned with the
// Earth about its axis e_L = (0, cos lat, sin lat) by W t.
Vec3 gravityInN0(double t_s, double latitude_rad, double g) {
  const Vec3 e(0.0, std::cos(latitude_rad), std::sin(latitude_rad));
  return Eigen::AngleAxisd(kEarthRate * t_s, e) * Vec3(0.0, 0.0, g);
}

// The gyro-tracked attitude against b0 and the cell means of the specific force in b0.
struct Tracked {
  std::vector<Vec3> cell_u_b0;
  std::vector<BlockInterval> cells;
  Quat q_b_to_b0 = Quat::Identity();  // at the span's end
  double sway_peak_rad = 0.0;
};

Tracked track(std::span<const ImuSample> s, double t0, int n_cells) {
  Tracked out;
  const double span = s.back().t - t0;
  std::vector<Vec3> dv_sum(static_cast<std::size_t>(n_cells), Vec3::Zero());
  std::vector<double> dt_sum(dv_sum.size(), 0.0), start(dv_sum.size(), span);
  Quat q = Quat::Identity();
  double t_prev = t0;
  for (const ImuSample& x : s) {
    const double dt = x.t - t_prev;
    const Quat q_mid = q * quatFromRotationVector(0.5 * x.dtheta);
    q = (q * quatFromRotationVector(x.dtheta)).normalized();
    out.sway_peak_rad =
        std::max(out.sway_peak_rad, 2.0 * std::acos(std::min(1.0, std::abs(q.w()))));
    const auto k = static_cast<std::size_t>(
        std::clamp(static_cast<int>((x.t - 0.5 * dt - t0) / span * n_cells), 0, n_cells - 1));
    dv_sum[k] += q_mid * x.dvel;
    dt_sum[k] += dt;
    start[k] = std::min(start[k], t_prev - t0);
    t_prev = x.t;
  }
  for (std::size_t k = 0; k < dv_sum.size(); ++k) {
    if (!(dt_sum[k] > 0.0)) continue;  // an empty cell: the caller refuses
    out.cell_u_b0.push_back(dv_sum[k] / dt_sum[k]);
    out.cells.push_back(BlockInterval{start[k], dt_sum[k]});
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

// Least squares by Gauss-Newton on (rotation in n0, latitude): C = C_hat exp([phi x]);
// free_latitude false holds the latitude (3 parameters). residual_n0: the residuals, one column
// per n0 axis (East, North, Up), J_n0 their derivatives; the covariance is set by the caller.
struct Fit {
  Mat3 C_b0_n0 = Mat3::Identity();
  double latitude_rad = 0.0;
  Mat4 covariance = Mat4::Zero();
  Eigen::MatrixXd residual_n0;
  std::array<Eigen::MatrixXd, 3> J_n0;  // d residual / d parameters, per n0 axis (K x 4)
  bool determined = false;
};

using AxisMatrices = std::array<Eigen::MatrixXd, 3>;

Fit gaussNewton(const std::vector<Block>& blocks, Fit fit, double g, bool free_latitude,
                int iterations) {
  const int n = free_latitude ? 4 : 3;
  const auto K = static_cast<Eigen::Index>(blocks.size());
  for (int it = 0; it <= iterations; ++it) {
    std::array<Eigen::MatrixXd, 3> J;
    J.fill(Eigen::MatrixXd::Zero(K, 4));
    fit.residual_n0.setZero(K, 3);
    const Mat3 C_n0_b0 = fit.C_b0_n0.transpose();
    for (Eigen::Index k = 0; k < K; ++k) {
      const Block& b = blocks[static_cast<std::size_t>(k)];
      const Vec3 a = gravityInN0(b.t_s, fit.latitude_rad, g);
      fit.residual_n0.row(k) = (C_n0_b0 * (b.u_b0 - fit.C_b0_n0 * a)).transpose();
      Eigen::Matrix<double, 3, 4> Jk;
      Jk.leftCols<3>() = -skew(a);  // d(C exp([phi x]) a)/dphi = -C [a x], resolved in n0
      constexpr double kH = 1e-6;
      Jk.col(3) = (gravityInN0(b.t_s, fit.latitude_rad + kH, g) - a) / kH;
      for (int i = 0; i < 3; ++i) J[static_cast<std::size_t>(i)].row(k) = Jk.row(i);
    }
    fit.J_n0 = J;
    Mat4 JtJ = Mat4::Zero();
    Vec4 Jtr = Vec4::Zero();
    for (std::size_t i = 0; i < 3; ++i) {
      JtJ += J[i].transpose() * J[i];
      Jtr += J[i].transpose() * fit.residual_n0.col(static_cast<Eigen::Index>(i));
    }
    const Eigen::MatrixXd N = JtJ.topLeftCorner(n, n);
    Eigen::FullPivLU<Eigen::MatrixXd> lu(N);
    fit.determined = lu.rank() == n;
    if (!fit.determined || it == iterations) return fit;
    const Eigen::VectorXd dx = lu.solve(Jtr.head(n));
    fit.C_b0_n0 = fit.C_b0_n0 * quatFromRotationVector(dx.head<3>()).toRotationMatrix();
    if (free_latitude) fit.latitude_rad += dx(3);
  }
  return fit;
}

// The inverse covariance of each n0 axis' residuals over the blocks (white, bounded velocity
// and random walk on the floor the sensors' white noise sets: nav/alignment_uncertainty.h);
// false when one cannot be formed. The accelerometers' noise is white on every axis; the gyros'
// angle random walk tilts gravity, which moves the horizontal axes only.
bool residualCovariances(const BlockStructures& st, const Eigen::MatrixXd& residual_n0,
                         const SensorWhiteNoise& noise, double g, AxisMatrices* cov_n0) {
  const Eigen::Index K = st.t_s.size();
  for (int i = 0; i < 3; ++i) {
    const double walk = i < 2 ? g * g * noise.gyro_rad2_per_s : 0.0;
    const BlockResidualCovariance c =
        blockResidualCovariance(st, residual_n0.col(i), noise.accel_m2_per_s3, walk);
    if (!c.ok) return false;
    // A floor far below any sensor's noise keeps exact data's covariance invertible.
    (*cov_n0)[static_cast<std::size_t>(i)] = c.covariance + 1e-24 * Eigen::MatrixXd::Identity(K, K);
  }
  return true;
}

// The fit by ordinary least squares (robust: it leans on no assumed correlation), its
// covariance the sandwich N^-1 (sum J_i^T S_i J_i) N^-1 with the residuals' covariance S_i over
// the blocks per n0 axis estimated from what the fit leaves.
Fit fitWithCovariance(const std::vector<Block>& blocks, const BlockStructures& st,
                      const SensorWhiteNoise& noise, const Fit& start, double g, bool free_latitude,
                      int iterations) {
  Fit fit = gaussNewton(blocks, start, g, free_latitude, iterations);
  AxisMatrices cov;
  if (!fit.determined || !residualCovariances(st, fit.residual_n0, noise, g, &cov)) {
    fit.determined = false;
    return fit;
  }
  const int n = free_latitude ? 4 : 3;
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(n, n), M = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t i = 0; i < 3; ++i) {
    const Eigen::MatrixXd J = fit.J_n0[i].leftCols(n);
    N += J.transpose() * J;
    M += J.transpose() * cov[i] * J;
  }
  const Eigen::MatrixXd N_inv = N.inverse();
  fit.covariance = Mat4::Zero();
  fit.covariance.topLeftCorner(n, n) = N_inv * M * N_inv;
  return fit;
}

// The blocks (nav/alignment_uncertainty.h: triangular weightings of two windows' cells) and
// their noise structures; structures.ok false when a cell is empty.
struct Blocks {
  std::vector<Block> blocks;
  BlockStructures structures;
};

Blocks blocksOf(const Tracked& tr, int n_cells) {
  Blocks out;
  if (static_cast<int>(tr.cells.size()) != n_cells) return out;
  out.structures = triangularBlockStructures(tr.cells, kCellsPerWindow);
  if (!out.structures.ok) return out;
  for (Eigen::Index k = 0; k < out.structures.t_s.size(); ++k) {
    Block b;
    for (Eigen::Index j = 0; j < out.structures.weights.cols(); ++j)
      b.u_b0 += out.structures.weights(k, j) * tr.cell_u_b0[static_cast<std::size_t>(j)];
    b.t_s = out.structures.t_s(k);
    out.blocks.push_back(b);
  }
  return out;
}

// The rate at which gravity turned in b0 between the first and last block, and the mean |u_k|
// less site gravity.
void blockStatistics(const std::vector<Block>& blocks, double g, InertialAlignmentResult* r) {
  const Block &first = blocks.front(), &last = blocks.back();
  const double cos_turn =
      std::clamp(first.u_b0.normalized().dot(last.u_b0.normalized()), -1.0, 1.0);
  r->gravity_turn_rate_radps = std::acos(cos_turn) / (last.t_s - first.t_s);
  double norm_sum = 0.0;
  for (const Block& b : blocks) norm_sum += b.u_b0.norm();
  r->accel_bias_up_mps2 = norm_sum / static_cast<double>(blocks.size()) - g;
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
  const int n_cells = (o.blocks + 1) * kCellsPerWindow;
  if (s.size() < 2 * static_cast<std::size_t>(n_cells)) {
    return fail(AlignmentStatus::kTooShort, "fewer than two samples per block's cell");
  }
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (!(s[i].t > s[i - 1].t)) {
      return fail(AlignmentStatus::kBadTimestamps, "time stamps not increasing");
    }
  }
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
  if (std::abs(std::cos(site.latitude_rad)) < o.min_cos_latitude) {
    return fail(AlignmentStatus::kHeadingUnobservable,
                "near the pole gravity turns about itself: no heading");
  }
  const double g = siteGravity(site);
  const Tracked tr = track(s, t0, n_cells);
  const Blocks bl = blocksOf(tr, n_cells);
  if (!bl.structures.ok)
    return fail(AlignmentStatus::kBadTimestamps, "a gap in the time stamps leaves a block empty");
  InertialAlignmentResult r;
  r.duration_s = duration;
  r.samples = static_cast<int>(s.size());
  r.blocks = static_cast<int>(bl.blocks.size());
  r.sway_peak_rad = tr.sway_peak_rad;
  blockStatistics(bl.blocks, g, &r);

  Fit fit;
  fit.latitude_rad = site.latitude_rad;
  fit.C_b0_n0 = wahba(bl.blocks, site.latitude_rad, g);
  const SensorWhiteNoise noise = sensorWhiteNoise(s);
  fit = fitWithCovariance(bl.blocks, bl.structures, noise, fit, g, false, o.iterations);
  r.residual_rms_rad =
      fit.residual_n0.norm() / std::sqrt(static_cast<double>(bl.blocks.size())) / g;
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
  const Fit lat_fit =
      fitWithCovariance(bl.blocks, bl.structures, noise, fit, g, true, o.iterations);
  r.implied_latitude_rad = lat_fit.determined ? lat_fit.latitude_rad : std::nan("");
  r.sigma_implied_latitude_rad =
      lat_fit.determined ? std::sqrt(lat_fit.covariance(3, 3)) : std::nan("");
  r.status = AlignmentStatus::kOk;
  return r;
}

}  // namespace imubench::nav
