#include "nav/alignment_uncertainty.h"

#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace imubench::nav {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Restricted log-likelihood of r for the covariance V with the fixed part X; -inf where V is not
// positive definite.
double reml(const MatrixXd& V, const MatrixXd& X, const VectorXd& r) {
  const Eigen::LLT<MatrixXd> llt(V);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const MatrixXd ViX = llt.solve(X);
  const VectorXd Vir = llt.solve(r);
  const Eigen::LLT<MatrixXd> llt_x(X.transpose() * ViX);
  if (llt_x.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const VectorXd Xt_Vir = X.transpose() * Vir;
  const double quad = r.dot(Vir) - Xt_Vir.dot(llt_x.solve(Xt_Vir));
  const double logdet_v = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  const double logdet_x = 2.0 * llt_x.matrixLLT().diagonal().array().log().sum();
  return -0.5 * (quad + logdet_v + logdet_x);
}

// Fourth differences' mean square / 70 (their variance for white increments), per unit time.
double whiteIntensity(std::span<const ImuSample> s, Vec3 ImuSample::*field) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 4; k < s.size(); ++k) {
    const Vec3 d4 = s[k].*field - 4.0 * (s[k - 1].*field) + 6.0 * (s[k - 2].*field) -
                    4.0 * (s[k - 3].*field) + s[k - 4].*field;
    sum += d4.squaredNorm() / 3.0;
    ++n;
  }
  const double dt = (s.back().t - s.front().t) / static_cast<double>(s.size() - 1);
  return n > 0 && dt > 0.0 ? sum / static_cast<double>(n) / 70.0 / dt : 0.0;
}

}  // namespace

AlignmentUncertainty alignmentUncertainty(std::span<const ImuSample> samples, const Site& site,
                                          const AlignmentResult& a) {
  AlignmentUncertainty u;
  const std::size_t n = samples.size();
  if (n < 2 || !a.ok()) return u;
  // The scatter of kBlocks block means of the rates (increments over the block's time): for
  // white noise the same sigma as the per-sample deviation / sqrt(N); for sway whose period is
  // short against a block it is what is left after averaging, not the sway's amplitude.
  constexpr int kBlocks = 10;
  const int blocks = n >= std::size_t{20} * kBlocks ? kBlocks : 2;
  Vec3 sf = Vec3::Zero(), sw = Vec3::Zero();
  for (int b = 0; b < blocks; ++b) {
    const std::size_t k0 = n * static_cast<std::size_t>(b) / static_cast<std::size_t>(blocks);
    const std::size_t k1 = n * static_cast<std::size_t>(b + 1) / static_cast<std::size_t>(blocks);
    Vec3 dv = Vec3::Zero(), dth = Vec3::Zero();
    for (std::size_t k = k0; k < k1; ++k) {
      dv += samples[k].dvel;
      dth += samples[k].dtheta;
    }
    const double T = samples[k1 - 1].t -
                     (k0 == 0 ? samples[0].t - (samples[1].t - samples[0].t) : samples[k0 - 1].t);
    const Vec3 df = dv / T - a.f_mean_B, dw = dth / T - a.w_mean_B;
    sf += df.cwiseProduct(df);
    sw += dw.cwiseProduct(dw);
  }
  const double B = static_cast<double>(blocks);
  // RMS over the axes of the standard deviation of each axis' mean.
  const double sigma_f = std::sqrt(sf.sum() / 3.0 / (B - 1.0) / B);
  const double sigma_w = std::sqrt(sw.sum() / 3.0 / (B - 1.0) / B);
  const double g = a.f_mean_B.norm();
  const double cos_lat = std::cos(site.latitude_rad);
  u.samples = static_cast<int>(n);
  u.sigma_tilt_rad = sigma_f / g;
  u.heading_rad_per_gyro_bias = 1.0 / (kEarthRate * cos_lat);
  u.sigma_heading_rad = sigma_w * u.heading_rad_per_gyro_bias;
  const Vec3 up = a.f_mean_B / g;
  const double w_up = a.w_mean_B.dot(up);
  u.horizontal_rate_radps = (a.w_mean_B - w_up * up).norm();
  u.implied_latitude_rad = std::abs(w_up) <= kEarthRate ? std::asin(w_up / kEarthRate)
                                                        : std::numeric_limits<double>::quiet_NaN();
  u.sigma_implied_latitude_rad = sigma_w / (kEarthRate * std::max(1e-3, std::abs(cos_lat)));
  u.gyro_bias_up_radps = w_up - kEarthRate * std::sin(site.latitude_rad);
  u.accel_bias_up_mps2 = g - siteGravity(site);
  return u;
}

SensorWhiteNoise sensorWhiteNoise(std::span<const ImuSample> samples) {
  SensorWhiteNoise out;
  if (samples.size() < 5) return out;
  out.gyro_rad2_per_s = whiteIntensity(samples, &ImuSample::dtheta);
  out.accel_m2_per_s3 = whiteIntensity(samples, &ImuSample::dvel);
  return out;
}

BlockStructures triangularBlockStructures(std::span<const BlockInterval> cells,
                                          int cells_per_window) {
  BlockStructures out;
  const auto M = static_cast<Eigen::Index>(cells.size());
  const Eigen::Index m = cells_per_window;
  if (m < 1 || M % m != 0 || M / m < 5) return out;
  for (const BlockInterval& c : cells)
    if (!(c.duration_s > 0.0)) return out;
  const Eigen::Index windows = M / m, K = windows - 1;
  std::vector<double> w_start(static_cast<std::size_t>(windows)), w_len(w_start.size(), 0.0);
  for (Eigen::Index j = 0; j < M; ++j) {
    const auto w = static_cast<std::size_t>(j / m);
    if (j % m == 0) w_start[w] = cells[static_cast<std::size_t>(j)].start_s;
    w_len[w] += cells[static_cast<std::size_t>(j)].duration_s;
  }
  // Block k: (mean over window k+1 - mean over window k of the cumulative velocity) / spacing;
  // a cell at time t in window k weighs (t - window start) / (len_k spacing), in window k+1
  // (window end - t) / (len_{k+1} spacing), times its duration.
  out.weights = MatrixXd::Zero(K, M);
  out.t_s.resize(K);
  VectorXd spacing(K);
  for (Eigen::Index k = 0; k < K; ++k) {
    const auto a = static_cast<std::size_t>(k), b = a + 1;
    spacing(k) = 0.5 * (w_len[a] + w_len[b]);
    for (Eigen::Index j = k * m; j < (k + 2) * m; ++j) {
      const BlockInterval& c = cells[static_cast<std::size_t>(j)];
      const double mid = c.start_s + 0.5 * c.duration_s;
      const double ramp = j < (k + 1) * m ? (mid - w_start[a]) / w_len[a]
                                          : (w_start[b] + w_len[b] - mid) / w_len[b];
      out.weights(k, j) = ramp * c.duration_s / spacing(k);
    }
    out.weights.row(k) /= out.weights.row(k).sum();
    out.t_s(k) = 0.0;  // the weighted mean time: exact for a linear signal
    for (Eigen::Index j = k * m; j < (k + 2) * m; ++j) {
      const BlockInterval& c = cells[static_cast<std::size_t>(j)];
      out.t_s(k) += out.weights(k, j) * (c.start_s + 0.5 * c.duration_s);
    }
  }
  // Cells: white noise' means (1 / duration), and a unit Wiener process' means from 0 at the
  // span's start (the earlier cell's mid-time for two cells, start + duration / 3 for one).
  VectorXd inv_len(M);
  MatrixXd walk_cells(M, M);
  for (Eigen::Index i = 0; i < M; ++i) {
    const BlockInterval& c = cells[static_cast<std::size_t>(i)];
    inv_len(i) = 1.0 / c.duration_s;
    walk_cells(i, i) = c.start_s + c.duration_s / 3.0;
    for (Eigen::Index j = i + 1; j < M; ++j)
      walk_cells(i, j) = walk_cells(j, i) = c.start_s + 0.5 * c.duration_s;
  }
  out.white = out.weights * inv_len.asDiagonal() * out.weights.transpose();
  out.walk = out.weights * walk_cells * out.weights.transpose();
  // Independent unit window-mean velocities: block k = (v_{k+1} - v_k) / spacing_k.
  out.bounded = MatrixXd::Zero(K, K);
  for (Eigen::Index k = 0; k < K; ++k) {
    out.bounded(k, k) = 2.0 / (spacing(k) * spacing(k));
    if (k + 1 < K)
      out.bounded(k, k + 1) = out.bounded(k + 1, k) = -1.0 / (spacing(k) * spacing(k + 1));
  }
  out.ok = true;
  return out;
}

BlockResidualCovariance blockResidualCovariance(const BlockStructures& st, const VectorXd& residual,
                                                double white_intensity, double walk_intensity) {
  BlockResidualCovariance out;
  const Eigen::Index K = st.t_s.size();
  if (!st.ok || residual.size() != K) return out;
  std::array<MatrixXd, 3> m{st.white, st.bounded, st.walk};
  const double floor_white = white_intensity * m[0].trace(),
               floor_walk = walk_intensity * m[2].trace();
  const MatrixXd floor = white_intensity * m[0] + walk_intensity * m[2];
  for (MatrixXd& x : m) x *= static_cast<double>(K) / x.trace();  // mean diagonal 1
  MatrixXd X(K, 2);
  X.col(0).setOnes();
  X.col(1) = st.t_s / st.t_s.maxCoeff();
  // Floor plus the white and bounded processes' variances x_i from {0} and a grid of powers of
  // 10 of the residuals' mean square, then a finer grid about the best. The random walk stays
  // the gyros' measured one: a free one lets a sway's slow beat against the windows pose as a
  // random walk (a ship's 9.7 s surge against 11.4 s windows: 13 deg stated for 0.3 deg).
  const double ms = residual.squaredNorm() / static_cast<double>(K);
  const MatrixXd jitter =
      (1e-9 * (ms + floor.trace() / static_cast<double>(K)) + 1e-300) * MatrixXd::Identity(K, K);
  std::array<double, 3> best_e{-99.0, -99.0, -99.0};  // log10(x_i / ms); -99: none
  double best = -std::numeric_limits<double>::infinity();
  auto covariance = [&](const std::array<double, 3>& e) {
    MatrixXd V = floor + jitter;
    for (std::size_t i = 0; i < 3; ++i)
      if (e[i] > -98.0) V += ms * std::pow(10.0, e[i]) * m[i];
    return V;
  };
  auto search = [&](const std::array<double, 3>& centre, double half, double step) {
    std::array<std::vector<double>, 3> grid;
    for (std::size_t i = 0; i < 3; ++i) {
      grid[i].push_back(-99.0);
      if (i == 2) continue;  // the random walk is the gyros' (measured), not the residuals'
      if (centre[i] < -98.0 && half < 1.0) continue;  // refining a process that is absent
      const double c = centre[i] < -98.0 ? 0.0 : centre[i];
      const int steps = static_cast<int>(std::floor(2.0 * half / step + 1e-9));
      for (int k = 0; k <= steps; ++k) grid[i].push_back(c - half + k * step);
    }
    for (double e0 : grid[0]) {
      for (double e1 : grid[1]) {
        for (double e2 : grid[2]) {
          const double l = reml(covariance({e0, e1, e2}), X, residual);
          if (l > best) {
            best = l;
            best_e = {e0, e1, e2};
          }
        }
      }
    }
  };
  search({-2.0, -2.0, -2.0}, 3.0, 1.0);
  search(best_e, 0.5, 0.125);
  if (!std::isfinite(best)) return out;
  out.covariance = covariance(best_e);
  std::array<double, 3> trace{floor_white, 0.0, floor_walk};
  for (std::size_t i = 0; i < 3; ++i)
    if (best_e[i] > -98.0) trace[i] += ms * std::pow(10.0, best_e[i]) * static_cast<double>(K);
  const double total = trace[0] + trace[1] + trace[2];
  if (total > 0.0) {
    out.white_share = trace[0] / total;
    out.bounded_share = trace[1] / total;
    out.walk_share = trace[2] / total;
  }
  out.ok = true;
  return out;
}

}  // namespace imubench::nav
