// Coarse alignment of a swaying IMU (a vehicle rocking on its suspension, a ship at its
// moorings) by gravity in the inertial frame (inertial-frame / "optimisation-based" coarse
// alignment; seed digest: alignment).
//
// Frames: b0 is the body frame at the span's start, frozen in inertial space; n0 is the local
// level frame L at the start, frozen likewise. The gyros track the body against b0 exactly
// whatever the sway (C_b0_b(t) from the integrated increments), and the L frame turns against
// n0 with the Earth, about the Earth's axis e_L = (0, cos lat, sin lat) by W t. At a point that
// does not translate on average the specific force is gravity's reaction, so the block means of
//   u_k = mean over block k of C_b0_b(t) f_B(t)      (sway's own rotation removed exactly;
//                                                    what is left of its lever-arm
//                                                    accelerations is a velocity change / block)
// obey u_k = C_b0_n0 a_k, a_k = R(e_L, W t_k) (0, 0, g): the gravity direction turns on a cone
// about the Earth's axis. The constant C_b0_n0 (= C_BL at the start) is the rotation that fits
// the u_k to the a_k (Wahba's problem, solved by SVD), refined together with the latitude by
// Gauss-Newton; its heading comes from the direction in which gravity turns (W cos lat), as a
// static gyrocompass' heading comes from the horizontal Earth rate.
//
// Blocks: the span is cut into windows; a block is the mean over the next window less the mean
// over this one of the cumulative velocity in b0, over their spacing (a triangular weighting of
// the specific force): a sway's surge and heave leave only the change of a window-mean velocity,
// and a sway much faster than a window is averaged out instead of aliased in.
//
// Uncertainty: the fit is ordinary least squares, its 4x4 covariance of (rotation in n0,
// latitude) the sandwich N^-1 (J^T S J) N^-1 with S the covariance of the blocks' residuals over
// the blocks per n0 axis (nav/alignment_uncertainty.h: white noise, the bounded velocity a sway
// leaves, whose changes telescope over the span, and the gyros' angle random walk, which tilts
// gravity in b0 by a walking angle; the sensors' noise measured from the samples, the sway's
// size from the residuals). A gyro bias turns b0 against inertial space like the Earth does: its
// East component b_E adds b_E / (W cos lat) rad of heading that no span can see (stated, as for
// the static alignment). Refused with the reason: too short, the residuals too large for a point at
// rest on average (the IMU translates, or its gyro bias turns gravity far faster than the Earth: a
// consumer MEMS gyro cannot gyrocompass), the heading unobservable (polar site).
#pragma once

#include <span>
#include <string>

#include "nav/alignment.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"
#include "nav/rotation.h"

namespace imubench::nav {

struct InertialAlignmentOptions {
  // Blocks (one per boundary of blocks + 1 windows): each gives one gravity vector in b0; 20
  // leave 18 degrees of freedom for the residuals' covariance and windows of 3 to 15 s over
  // 60 to 300 s, long against a vehicle's sway, a few periods of a ship's.
  int blocks = 20;
  // Shortest span: a block must hold a few sway periods (ships sway at 5..20 s).
  double min_duration_s = 60.0;
  // Largest RMS residual of the block vectors, as an angle (rad): noise leaves 1e-5..1e-4 rad
  // at navigation grade, a ship's heave (0.5 m/s^2 at 8 s) what its velocity change over a
  // block leaves, up to 5e-3 rad over 15 s blocks; a MEMS gyro bias of 0.1 deg/s turns gravity
  // by 0.1 rad in a minute, and a vehicle that drives leaves accelerations of 0.1 g.
  double max_residual_rad = 1e-2;
  // Gauss-Newton iterations after the SVD start (the problem is nearly linear).
  int iterations = 5;
  // |cos lat| below this: the cone degenerates to the pole's axis, heading unobservable.
  double min_cos_latitude = 0.05;

  bool IsValid(std::string* why) const;
};

struct InertialAlignmentResult {
  AlignmentStatus status = AlignmentStatus::kInvalidOptions;
  std::string message;  // why, when status != kOk
  Quat q_BtoL_start =
      Quat::Identity();                // attitude at the span's start (the first interval's start)
  Quat q_BtoL_end = Quat::Identity();  // attitude at the span's last sample
  double duration_s = 0.0;
  int samples = 0;
  int blocks = 20;
  // 1-sigma about the start frame's axes (sensor noise and the sway the residuals show).
  double sigma_tilt_rad = 0.0;             // the larger of East and North
  double sigma_heading_rad = 0.0;          // about Up
  double heading_rad_per_gyro_bias = 0.0;  // 1 / (W cos lat)
  double implied_latitude_rad = 0.0;       // the latitude whose cone fits best
  double sigma_implied_latitude_rad = 0.0;
  double accel_bias_up_mps2 = 0.0;  // mean |u_k| - site gravity
  double residual_rms_rad = 0.0;    // the fit's RMS residual as an angle
  double sway_peak_rad = 0.0;       // largest attitude excursion from the start over the span
  // The rate at which gravity turned in b0 between the first and last block (rad/s; the Earth
  // turns it at W cos lat): far above, a gyro bias hides the Earth rate.
  double gravity_turn_rate_radps = 0.0;

  bool ok() const { return status == AlignmentStatus::kOk; }
};

// Alignment of the span (time-ordered samples; the first interval's start is taken as
// samples[0].t - (samples[1].t - samples[0].t)).
InertialAlignmentResult inertialAlign(std::span<const ImuSample> samples, const Site& site,
                                      const InertialAlignmentOptions& options = {});

}  // namespace imubench::nav
