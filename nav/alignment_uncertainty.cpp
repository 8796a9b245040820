#include "nav/alignment_uncertainty.h"

#include <cmath>
#include <limits>

namespace imubench::nav {

AlignmentUncertainty alignmentUncertainty(std::span<const ImuSample> samples, const Site& site,
                                          const AlignmentResult& a) {
  AlignmentUncertainty u;
  const std::size_t n = samples.size();
  if (n < 2 || !a.ok()) return u;
  // The scatter of kBlocks block means of the rates (increments over the block's time): for
  // white noise the same sigma as the per-sample deviation / sqrt(N); for sway whose period is
  // short against a block it is what is left after averaging, not the sway's amplitude.
  constexpr int kBlocks = 10;
  const int blocks = n >= 20 * kBlocks ? kBlocks : 2;
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

}  // namespace imubench::nav
