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

#include <Eigen/Dense>
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

// The sway-tolerant alignment (nav/inertial_alignment.h) fits blocks of the specific force in
// the inertial body frame b0: block k is the mean over window k + 1 less the mean over window k of
// the cumulative velocity, over the windows' spacing (a triangular weighting of the specific force
// over both windows). Averaging the velocity over a window, not taking it at one instant, keeps a
// sway much faster than a window out of the blocks instead of aliasing it into them. What the
// blocks keep besides gravity is not white noise; along one axis of n0 it is the sum of three
// processes, each with its own covariance over the blocks:
//  - white: what averages like noise (accelerometer noise);
//  - bounded velocity: a sway's surge or heave leaves the change of its window-mean velocity,
//    a velocity that stays bounded: neighbouring blocks share a window (correlation -1/2) and the
//    sum over the span telescopes to one velocity change, so a slope fitted through them is far
//    better known than their scatter says;
//  - random walk: the gyros' angle random walk tilts gravity in b0 by an angle that walks from
//    zero at the span's start: the blocks correlate over the whole span, and a slope fitted
//    through them is worse known than their scatter says.
// The sensors' white noise is measured from the samples themselves (sensorWhiteNoise): it sets
// a floor of white and random walk that the residuals cannot talk down; on top of it the sizes
// of the white and bounded processes come from the residuals (restricted maximum likelihood,
// the residuals' own fixed part a constant and a slope in time). The random walk is the gyros'
// alone: a gyro whose noise is not white (flicker, a bias that wanders over the span) is not in
// it; a constant East gyro bias is stated apart (heading_rad_per_gyro_bias).
struct BlockInterval {
  double start_s = 0.0;     // since the span's start
  double duration_s = 0.0;  // > 0
};

// White noise intensities of the increments, from their fourth differences (a smooth motion's
// fourth difference over a 100 Hz step is (w dt)^4 of it: a 1 Hz sway leaves 2e-6 of its
// amplitude; vibration faster than that counts as noise, which only makes the sigma cautious).
struct SensorWhiteNoise {
  double gyro_rad2_per_s = 0.0;  // angle random walk^2, per axis (mean of the three)
  double accel_m2_per_s3 = 0.0;  // velocity random walk^2, per axis (mean of the three)
};

SensorWhiteNoise sensorWhiteNoise(std::span<const ImuSample> samples);

// The blocks over cells (consecutive intervals, their means the data): windows of
// cells_per_window cells, one block per boundary between two windows.
struct BlockStructures {
  Eigen::MatrixXd weights;  // blocks x cells: block = weights * cell means (rows sum to 1)
  Eigen::VectorXd t_s;      // the block's centre (the windows' boundary), since the span's start
  // Covariances over the blocks per unit intensity: white (unit^2 s), bounded velocity (per
  // unit^2 s^2 of window-mean velocity), random walk (per unit^2 / s).
  Eigen::MatrixXd white, bounded, walk;
  bool ok = false;  // false: fewer than 5 windows, or a cell not of positive duration
};

BlockStructures triangularBlockStructures(std::span<const BlockInterval> cells,
                                          int cells_per_window);

struct BlockResidualCovariance {
  Eigen::MatrixXd covariance;  // K x K, in the residual's units squared
  // Each process' share of the mean diagonal (they sum to 1), floor included.
  double white_share = 0.0;
  double bounded_share = 0.0;
  double walk_share = 0.0;
  bool ok = false;  // false: structures not ok or the residual's size differs
};

// Floor: white_intensity (residual units^2 x s: the white noise' intensity) and walk_intensity
// (residual units^2 / s: the random walk's) along this axis.
BlockResidualCovariance blockResidualCovariance(const BlockStructures& structures,
                                                const Eigen::VectorXd& residual,
                                                double white_intensity, double walk_intensity);

}  // namespace imubench::nav
