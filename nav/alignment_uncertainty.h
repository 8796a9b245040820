// What a static coarse alignment (nav/alignment.h) can say about itself: the 1-sigma of roll,
// pitch and heading from the sensor noise over the span, the latitude the measured Earth rate
// implies, and the two biases a single static orientation can separate (the vertical
// accelerometer bias |f| - g, the vertical gyro bias w_up - W sin(lat) at the known site).
//
// Noise: the span is cut into 10 blocks; the scatter of the block means / sqrt(10) is the
// sigma of the span's mean (for white noise the per-sample deviation / sqrt(N); for sway with
// a period short against a block, what the averaging leaves). Tilt sigma = sigma(f mean) / g;
// heading sigma = sigma(w mean) / (W cos lat). A gyro bias b_E left in the East channel adds b_E /
// (W cos lat) rad of heading error that no static span can see (heading_rad_per_gyro_bias), an
// accelerometer bias b_h adds b_h / g of tilt: both are stated, not hidden in the sigma.
#pragma once

#include <span>

#include "nav/alignment.h"

namespace imubench::nav {

struct AlignmentUncertainty {
  double sigma_tilt_rad = 0.0;             // roll and pitch, noise only
  double sigma_heading_rad = 0.0;          // noise only
  double heading_rad_per_gyro_bias = 0.0;  // 1 / (W cos lat): rad of heading per rad/s of b_E
  double implied_latitude_rad = 0.0;       // asin(w_up / W); NaN when |w_up| > W (a gyro bias)
  double sigma_implied_latitude_rad = 0.0;
  double gyro_bias_up_radps = 0.0;     // w_up - W sin(site latitude)
  double accel_bias_up_mps2 = 0.0;     // |f| - site gravity
  double horizontal_rate_radps = 0.0;  // |w_h| (Earth's W cos lat plus any horizontal bias)
  int samples = 0;
};

// The alignment's own uncertainty for the span it used (a.ok() required).
AlignmentUncertainty alignmentUncertainty(std::span<const ImuSample> samples, const Site& site,
                                          const AlignmentResult& a);

}  // namespace imubench::nav
