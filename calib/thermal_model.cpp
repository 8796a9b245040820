#include "calib/thermal_model.h"

#include <algorithm>
#include <cmath>

namespace imubench::calib {

SensorModel thermalSensorsAt(const model::ThermalCoefficients& c, double temp_c, double temp_rate,
                             bool* extrapolated) {
  std::array<double, model::kTriadSize> a{}, g{};
  const auto pa = model::thermalTriadBlock(c, c.accel, temp_c, temp_rate, a.data());
  model::thermalTriadBlock(c, c.gyro, temp_c, temp_rate, g.data());
  if (extrapolated) *extrapolated = pa.extrapolated;
  return {TriadModel::fromBlock(a.data()), TriadModel::fromBlock(g.data())};
}

bool TemperatureRateOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(window_s) && window_s > 0.0)) {
    if (why) *why = "temperature rate window must be > 0 s";
    return false;
  }
  return true;
}

std::vector<double> temperatureRates(const nav::ImuSamples& imu,
                                     const TemperatureRateOptions& options) {
  // Running sums over the finite samples, with t and T taken relative to the first sample
  // (keeps the sums well conditioned over hours of data).
  const std::size_t n = imu.size();
  std::vector<double> rates(n, 0.0);
  if (n == 0) return rates;
  const double t0 = imu.front().t;
  const double T0 = std::isfinite(imu.front().temp_c) ? imu.front().temp_c : 0.0;
  std::vector<double> s1(n + 1, 0.0), st(n + 1, 0.0), sT(n + 1, 0.0), stt(n + 1, 0.0),
      stT(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const bool f = std::isfinite(imu[i].temp_c);
    const double t = imu[i].t - t0, T = f ? imu[i].temp_c - T0 : 0.0, w = f ? 1.0 : 0.0;
    s1[i + 1] = s1[i] + w;
    st[i + 1] = st[i] + w * t;
    sT[i + 1] = sT[i] + w * T;
    stt[i + 1] = stt[i] + w * t * t;
    stT[i + 1] = stT[i] + w * t * T;
  }
  const double half = 0.5 * options.window_s;
  std::size_t lo = 0, hi = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (imu[lo].t < imu[i].t - half) ++lo;
    while (hi < n && imu[hi].t <= imu[i].t + half) ++hi;
    const double m = s1[hi] - s1[lo];
    if (m < 2.0) continue;
    const double a = st[hi] - st[lo], b = sT[hi] - sT[lo];
    const double d = m * (stt[hi] - stt[lo]) - a * a;
    if (d > 0.0) rates[i] = (m * (stT[hi] - stT[lo]) - a * b) / d;
  }
  return rates;
}

ThermalApplyResult applyThermal(const model::ThermalCoefficients& c, const nav::ImuSamples& imu,
                                const ThermalApplyOptions& options) {
  ThermalApplyResult r;
  if (std::string why; !options.rate.IsValid(&why)) {
    r.status = Status::Error(why);
    return r;
  }
  for (std::size_t i = 0; i < imu.size(); ++i) {
    if (!std::isfinite(imu[i].temp_c)) {
      r.status = Status::Error("sample " + std::to_string(i + 1) +
                               " (t = " + std::to_string(imu[i].t) + " s) has no temperature");
      return r;
    }
    if (i > 0 && !(imu[i].t > imu[i - 1].t)) {
      r.status = Status::Error("sample times not increasing at sample " + std::to_string(i + 1));
      return r;
    }
  }
  r.temp_rate = temperatureRates(imu, options.rate);
  r.compensated.reserve(imu.size());
  r.extrapolated.assign(imu.size(), false);
  double prev_t = imu.empty() ? 0.0 : imu.front().t - (imu.size() > 1 ? imu[1].t - imu[0].t : 0.0);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const nav::ImuSample& s = imu[i];
    std::array<double, model::kTriadSize> a{}, g{};
    const auto p = model::thermalTriadBlock(c, c.accel, s.temp_c, r.temp_rate[i], a.data());
    model::thermalTriadBlock(c, c.gyro, s.temp_c, r.temp_rate[i], g.data());
    const double dt = s.t - prev_t;
    prev_t = s.t;
    // Increments are integrals of the readings: the affine inverse maps them with h dt.
    Mat3 G;
    Vec3 h;
    nav::ImuSample out = s;
    model::compensationAffine(g.data(), &G, &h);
    out.dtheta = G * s.dtheta + h * dt;
    model::compensationAffine(a.data(), &G, &h);
    out.dvel = G * s.dvel + h * dt;
    r.compensated.push_back(out);
    r.extrapolated[i] = p.extrapolated;
    if (p.extrapolated) ++r.extrapolated_count;
    r.temp_min_c = i == 0 ? s.temp_c : std::min(r.temp_min_c, s.temp_c);
    r.temp_max_c = i == 0 ? s.temp_c : std::max(r.temp_max_c, s.temp_c);
  }
  r.status = Status::Ok();
  return r;
}

}  // namespace imubench::calib
