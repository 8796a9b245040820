// Analytic coarse alignment from static data (double-vector / TRIAD with gravity and Earth
// rate).
//
// At rest the accelerometers measure f_B = C_BL (0, 0, g) and the gyros w_IB_B = C_BL w_IE_L,
// w_IE_L = (0, W cos(lat), W sin(lat)). Three L-frame vectors and their B-frame images
//   u1 = f,  u2 = f x w,  u3 = f x (f x w)
// form orthogonal triads in both frames; C_LB = T_L T_B^T with T the normalized columns.
// Roll and pitch come from f alone (exact for exact data); heading comes from the horizontal
// Earth-rate component: a gyro bias b_E (East, after levelling) gives a heading error of about
// b_E / (W cos(lat)) rad, which is why heading is coarse and fails near the poles.
#pragma once

#include <span>
#include <string>

#include "nav/earth.h"
#include "nav/imu_sample.h"
#include "nav/rotation.h"

namespace imubench::nav {

struct AlignmentOptions {
  // Shortest span accepted: averaging must beat sensor noise; a second is the least that
  // makes sense even for navigation-grade sensors (use minutes for a good heading).
  double min_duration_s = 1.0;
  // At least this many samples, so the static test below has blocks to compare.
  int min_samples = 8;
  // Static test: the span is split into this many blocks whose mean specific force and rate
  // must agree (white noise averages out, motion does not).
  int static_blocks = 4;
  // Largest allowed difference of block-mean specific force from the span mean, m/s^2
  // (motion detector; 0.05 m/s^2 passes MEMS noise at >= 1 s blocks and catches any table move).
  double max_block_accel_dev_mps2 = 0.05;
  // Largest allowed difference of block-mean angular rate from the span mean, rad/s
  // (0.1 deg/s passes MEMS noise and catches table rotation).
  double max_block_rate_dev_radps = 0.1 * kDegToRad;
  // |mean f| must be within this fraction of the site gravity (an accelerometer fault or a
  // moving/vibrating fixture otherwise).
  double max_gravity_rel_error = 0.02;
  // |mean w| must not exceed this multiple of the Earth rate: more means rotation or a gyro
  // bias so large that the heading would be meaningless.
  double max_rate_earth_multiple = 3.0;
  // Minimum sine of the angle between f and w: below it (near the poles) heading is
  // unobservable from Earth rate.
  double min_sin_f_w = 0.05;

  bool IsValid(std::string* why) const;
};

enum class AlignmentStatus {
  kOk,
  kTooShort,             // span shorter than min_duration_s / min_samples
  kBadTimestamps,        // non-increasing time stamps
  kNotStatic,            // block means disagree: the IMU moved
  kGravityMismatch,      // |f| far from site gravity
  kRateTooLarge,         // steady rotation or a gross gyro bias (mean w >> Earth rate)
  kHeadingUnobservable,  // f and w nearly parallel (polar site) or w zero
  kInvalidOptions,
};

struct AlignmentResult {
  AlignmentStatus status = AlignmentStatus::kInvalidOptions;
  std::string message;  // why, when status != kOk
  Quat q_BtoL = Quat::Identity();
  Mat3 C_LB = Mat3::Identity();
  Vec3 f_mean_B = Vec3::Zero();  // mean specific force over the span, m/s^2
  Vec3 w_mean_B = Vec3::Zero();  // mean angular rate over the span, rad/s
  double duration_s = 0.0;

  bool ok() const { return status == AlignmentStatus::kOk; }
};

// Attitude from mean specific force and mean angular rate (both in B) at the given latitude.
// Checks only geometry (f and w must not be parallel or zero).
AlignmentResult alignFromMeans(const Vec3& f_mean_B, const Vec3& w_mean_B, double latitude_rad,
                               const AlignmentOptions& opt = {});

// Coarse alignment of a static span of samples. The first sample's interval starts at
// samples[0].t - (samples[1].t - samples[0].t) (uniform rate assumed for its length).
AlignmentResult coarseAlign(std::span<const ImuSample> samples, const Site& site,
                            const AlignmentOptions& opt = {});

// (roll, pitch, heading) of q_BtoL in rad, for reports: C_LB = Rz(-heading) Rx(pitch) Ry(roll)
// (B = right, forward, up at zero angles; heading of the body y axis clockwise from North).
Vec3 rollPitchHeading(const Quat& q_BtoL);

}  // namespace imubench::nav
