#include "calib/explain/explain_noise.h"

#include <algorithm>
#include <cmath>

#include "calib/recording_checks.h"

namespace imubench::calib {
namespace {

// Channel c of sample i of a hold.
double channelValue(const HoldReadings& h, std::size_t i, int c) {
  return c < 3 ? h.accel[i](c) : h.gyro[i](c - 3);
}

// Sums of squared differences of consecutive m-sample cluster means, per channel, over holds.
AllanPoint clusterPoint(std::span<const HoldReadings> holds, std::size_t m, double dt) {
  AllanPoint p;
  p.tau_s = static_cast<double>(m) * dt;
  std::array<double, kExplainChannels> sum{};
  for (const HoldReadings& h : holds) {
    const std::size_t clusters = h.accel.size() / m;
    if (clusters < 2) continue;
    std::array<double, kExplainChannels> prev{};
    for (std::size_t k = 0; k < clusters; ++k) {
      // Summed as triads (the same additions in the same order as channel by channel).
      Vec3 sum_a = Vec3::Zero(), sum_g = Vec3::Zero();
      for (std::size_t i = k * m; i < (k + 1) * m; ++i) {
        sum_a += h.accel[i];
        sum_g += h.gyro[i];
      }
      std::array<double, kExplainChannels> mean{};
      for (int c = 0; c < kExplainChannels; ++c) {
        mean[c] = (c < 3 ? sum_a(c) : sum_g(c - 3)) / static_cast<double>(m);
        if (k > 0) sum[c] += (mean[c] - prev[c]) * (mean[c] - prev[c]);
      }
      prev = mean;
      if (k > 0) ++p.pairs;
    }
  }
  for (int c = 0; c < kExplainChannels; ++c) {
    p.adev[c] = p.pairs > 0 ? std::sqrt(0.5 * sum[c] / static_cast<double>(p.pairs)) : 0.0;
  }
  return p;
}

// Distinct readings of channel c in hold h: values closer than 1e-9 of the triad's largest
// magnitude are one (rounding of increments divided by their interval).
int distinctValues(const HoldReadings& h, int c) {
  std::vector<double> v;
  double mag = 0.0;
  v.reserve(h.accel.size());
  for (std::size_t i = 0; i < h.accel.size(); ++i) {
    v.push_back(channelValue(h, i, c));
    mag = std::max(mag, (c < 3 ? h.accel[i] : h.gyro[i]).norm());
  }
  return countDistinct(std::move(v), 1e-9 * mag + 1e-300);
}

void resolution(std::span<const HoldReadings> holds, NoiseFloor* nf) {
  for (int c = 0; c < kExplainChannels; ++c) {
    std::vector<int> n;
    for (const HoldReadings& h : holds) n.push_back(distinctValues(h, c));
    std::nth_element(n.begin(), n.begin() + static_cast<std::ptrdiff_t>(n.size() / 2), n.end());
    nf->distinct_values[c] = n[n.size() / 2];
    nf->resolution_limited[c] = nf->distinct_values[c] <= kMaxResolutionValues;
  }
}

}  // namespace

bool NoiseFloor::anyResolutionLimited() const {
  return std::any_of(resolution_limited.begin(), resolution_limited.end(),
                     [](bool b) { return b; });
}

NoiseFloor noiseFloor(std::span<const HoldReadings> holds, const NoiseFloorOptions& options) {
  NoiseFloor nf;
  if (holds.empty()) return nf;
  resolution(holds, &nf);
  const double dt = holds.front().dt;
  std::size_t longest = 0;
  for (const HoldReadings& h : holds) {
    longest = std::max(longest, h.accel.size());
    nf.total_static_s += static_cast<double>(h.accel.size()) * h.dt;
  }
  for (std::size_t m = 1; m <= longest / 2; m *= 2) {
    AllanPoint p = clusterPoint(holds, m, dt);
    if (p.pairs < options.min_pairs) break;
    for (int c = 0; c < kExplainChannels; ++c) {
      p.adev[c] = std::max(p.adev[c], c < 3 ? options.min_accel_adev : options.min_gyro_adev);
    }
    nf.curve.push_back(p);
  }
  if (nf.curve.empty()) return nf;
  for (int c = 0; c < kExplainChannels; ++c) {
    nf.white[c] = nf.curve.front().adev[c] * std::sqrt(nf.curve.front().tau_s);
    const auto best = std::min_element(
        nf.curve.begin(), nf.curve.end(),
        [c](const AllanPoint& a, const AllanPoint& b) { return a.adev[c] < b.adev[c]; });
    nf.bias_instability[c] = best->adev[c] / 0.664;
    nf.bias_instability_tau_s[c] = best->tau_s;
  }
  nf.status = Status::Ok();
  return nf;
}

double NoiseFloor::sigmaOfMean(int channel, double tau_s) const {
  if (curve.empty() || tau_s <= 0.0) return 0.0;
  const AllanPoint& first = curve.front();
  if (tau_s <= first.tau_s) return first.adev[channel] * std::sqrt(first.tau_s / tau_s);
  for (std::size_t k = 1; k < curve.size(); ++k) {
    if (tau_s <= curve[k].tau_s) {
      const double x0 = std::log(curve[k - 1].tau_s), x1 = std::log(curve[k].tau_s);
      const double y0 = std::log(curve[k - 1].adev[channel]), y1 = std::log(curve[k].adev[channel]);
      const double f = (std::log(tau_s) - x0) / (x1 - x0);
      return std::exp(y0 + f * (y1 - y0));
    }
  }
  return curve.back().adev[channel];
}

}  // namespace imubench::calib
