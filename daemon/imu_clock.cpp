#include "daemon/imu_clock.h"

#include <algorithm>

namespace imubench::daemon {

void ImuClockMap::addAnchor(double rx_unix_s, double t_imu_s) {
  if (!anchors_.empty() && t_imu_s == anchors_.back().t) return;  // the earlier is less delayed
  if (!anchors_.empty() &&
      (t_imu_s < anchors_.back().t || rx_unix_s - anchors_.back().rx > o_.window_s)) {
    anchors_.clear();
  }
  anchors_.push_back({rx_unix_s, t_imu_s});
  while (anchors_.size() > o_.max_anchors ||
         (anchors_.size() > 2 && rx_unix_s - anchors_.front().rx > o_.window_s)) {
    anchors_.pop_front();
  }
}

std::optional<double> ImuClockMap::imuTime(double unix_s) const {
  const std::optional<ImuClockLine> l = line();
  if (!l) return std::nullopt;
  return l->imuTime(unix_s);
}

std::optional<ImuClockLine> ImuClockMap::line() const {
  if (anchors_.size() < 2 ||
      anchors_.back().rx - anchors_.front().rx < o_.min_span_fraction * o_.window_s) {
    return std::nullopt;
  }
  // Centred sums, the receive times relative to the first (they are ~1.7e9 s: their squares
  // would lose every digit).
  const double n = static_cast<double>(anchors_.size());
  const Anchor& first = anchors_.front();
  double drx = 0.0, dt = 0.0;
  for (const Anchor& a : anchors_) drx += (a.rx - first.rx) / n, dt += (a.t - first.t) / n;
  const double rx0 = first.rx + drx, t0 = first.t + dt;
  double sxx = 0.0, sxy = 0.0;
  for (const Anchor& a : anchors_) {
    sxx += (a.rx - rx0) * (a.rx - rx0);
    sxy += (a.rx - rx0) * (a.t - t0);
  }
  if (!(sxx > 0.0) || !(sxy > 0.0)) return std::nullopt;
  const double rate = sxy / sxx;  // IMU seconds per wall second
  // The least-delayed anchor lies highest above the line (latest sample time for its receive
  // time).
  double lift = -1e300;
  for (const Anchor& a : anchors_) lift = std::max(lift, a.t - (t0 + rate * (a.rx - rx0)));
  return ImuClockLine{rx0, t0 + lift, rate};
}

}  // namespace imubench::daemon
