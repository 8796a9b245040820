#include "calib/noise.h"

#include <cmath>

namespace imubench::calib {
namespace {

constexpr double kUg = kMicroGToMps2;

bool validTriad(const TriadNoise& n, const char* name, std::string* why) {
  if (!(std::isfinite(n.white) && n.white >= 0.0)) {
    if (why) *why = std::string(name) + ".white: must be finite and >= 0";
    return false;
  }
  if (!(std::isfinite(n.bias_sigma) && n.bias_sigma >= 0.0)) {
    if (why) *why = std::string(name) + ".bias_sigma: must be finite and >= 0";
    return false;
  }
  if (!(std::isfinite(n.correlation_time_s) && n.correlation_time_s > 0.0)) {
    if (why) *why = std::string(name) + ".correlation_time_s: must be finite and > 0";
    return false;
  }
  return true;
}

// A grade's noise from its datasheet figures: gyro angle random walk (deg/sqrt(h)) and bias
// sigma (deg/h), accelerometer white noise (ug/sqrt(Hz)) and bias sigma (ug), and the bias
// correlation time of both triads (s).
NoiseModel gradeFromDatasheet(double gyro_arw_deg_rt_h, double gyro_bias_deg_h,
                              double accel_white_ug, double accel_bias_ug,
                              double correlation_time_s) {
  NoiseModel n;
  n.gyro.white = gyro_arw_deg_rt_h * kDegToRad / 60.0;
  n.gyro.bias_sigma = gyro_bias_deg_h * kDegPerHourToRadPerSec;
  n.accel.white = accel_white_ug * kUg;
  n.accel.bias_sigma = accel_bias_ug * kUg;
  n.gyro.correlation_time_s = n.accel.correlation_time_s = correlation_time_s;
  return n;
}

std::uint64_t splitmix64(std::uint64_t* x) {
  std::uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t rotl(std::uint64_t x, int k) {
  return (x << k) | (x >> (64 - k));
}

}  // namespace

NoiseModel NoiseModel::navigationGrade() {
  NoiseModel n;
  n.gyro.white = 0.002 * kDegToRad / 60.0;  // 0.002 deg/sqrt(h)
  n.accel.white = 20.0 * kUg;               // 20 ug/sqrt(Hz), i.e. (m/s)/sqrt(s)
  return n;
}

NoiseModel NoiseModel::navigationGradeDrifting() {
  NoiseModel n = navigationGrade();
  n.gyro.bias_sigma = 0.003 * kDegPerHourToRadPerSec;
  n.accel.bias_sigma = 10.0 * kUg;
  return n;
}

NoiseModel NoiseModel::tactical() {
  return gradeFromDatasheet(0.1, 1.0, 100.0, 100.0, 600.0);
}

NoiseModel NoiseModel::consumer() {
  return gradeFromDatasheet(0.5, 10.0, 200.0, 1000.0, 100.0);
}

bool NoiseModel::IsValid(std::string* why) const {
  return validTriad(accel, "noise.accel", why) && validTriad(gyro, "noise.gyro", why);
}

GaussianSource::GaussianSource(std::uint64_t seed) {
  std::uint64_t x = seed;
  for (auto& s : s_) s = splitmix64(&x);
}

std::uint64_t GaussianSource::uniform64() {
  // xoshiro256** (Blackman & Vigna).
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double GaussianSource::uniform() {
  return static_cast<double>(uniform64() >> 11) * 0x1.0p-53;
}

double GaussianSource::next() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u = 0.0, v = 0.0, s = 0.0;
  do {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double m = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = v * m;
  has_spare_ = true;
  return u * m;
}

std::optional<NoiseModel> NoiseModel::byName(const std::string& name) {
  if (name == "none") return none();
  if (name == "nav-grade") return navigationGrade();
  if (name == "nav-grade-drift") return navigationGradeDrifting();
  if (name == "tactical") return tactical();
  if (name == "consumer") return consumer();
  return std::nullopt;
}

}  // namespace imubench::calib
