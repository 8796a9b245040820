// The IMU's sample clock seen from the wall clock: where on the recording's time axis (the
// IMU's own sample times) a wall-clock instant falls, so a table reading taken at a known
// CLOCK_REALTIME instant can be placed among the IMU samples.
//
// Anchors are (kernel receive time, sample time) pairs of the samples that stand at their
// receive time (the last of each burst). A frame is never received before its sample is due,
// only later, by the sender's and the kernel's scheduling: the line through the anchors is the
// least-squares slope (the IMU clock's rate against the wall clock: 1 on a real bench, the time
// scale on a virtual one) moved to the least-delayed anchor (the lower envelope, as NTP's clock
// filter takes the least-delayed exchange). Scheduling jitter of the receiver then does not
// reach the table's time stamps.
//
//   ImuClockMap clock;
//   clock.addAnchor(rx_unix_s, t_imu);            // for every burst's last sample
//   std::optional<double> t = clock.imuTime(w);   // a table reading sampled at wall time w
//   auto line = clock.line();                      // one fit for several instants
#pragma once

#include <cstddef>
#include <deque>
#include <optional>

namespace imubench::daemon {

struct ImuClockMapOptions {
  // Wall seconds of anchors the line is fitted to: long enough that the slope is known to far
  // below the receive jitter over the window (ms over seconds), short enough that the clocks'
  // drift is a straight line over it.
  double window_s = 2.0;
  // Anchors kept at most (a sender of single samples at 1 kHz: 2000 in the window); the
  // oldest go first, so the fit's cost stays bounded.
  std::size_t max_anchors = 1024;
  // The anchors must span this fraction of the window before the map answers (a slope from a
  // few anchors milliseconds apart is mostly their jitter).
  double min_span_fraction = 0.25;
};

// The fitted map: IMU time = t0 + rate (unix_s - rx0).
struct ImuClockLine {
  double rx0 = 0.0, t0 = 0.0, rate = 1.0;
  double imuTime(double unix_s) const { return t0 + rate * (unix_s - rx0); }
};

class ImuClockMap {
 public:
  explicit ImuClockMap(ImuClockMapOptions o = {}) : o_(o) {}
  // A sample time that goes back, or an anchor a window after the previous one (the IMU
  // restarted or stopped), starts the map afresh; the same sample time again is ignored.
  void addAnchor(double rx_unix_s, double t_imu_s);
  void clear() { anchors_.clear(); }
  // The IMU time at wall instant unix_s; nullopt until the anchors span enough of the window.
  std::optional<double> imuTime(double unix_s) const;
  // The line imuTime evaluates (fitted over every anchor: evaluate it for several instants).
  std::optional<ImuClockLine> line() const;

 private:
  struct Anchor {
    double rx = 0.0, t = 0.0;
  };
  ImuClockMapOptions o_;
  std::deque<Anchor> anchors_;
};

}  // namespace imubench::daemon
