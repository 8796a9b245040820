// Pre-integration of one rotation run for the navigation-based calibration.
//
// The attitude of the navigation solution is propagated ONCE per outer iteration through the
// run with the current gyro coefficients p0 (exact rotation-vector quaternions, two-sample
// coning correction, L rotating with the Earth). Along the way the first-order sensitivity of
// the end attitude to the compensation is accumulated, so the Ceres cost never re-navigates:
// compensated increments are affine in the raw ones, dth = G dth_raw + h dt, so a change
// (dG, dh) of the compensation tilts the end attitude by the L-frame rotation vector
//     dpsi_L = sum_k C_LB(k) (dG dth_raw(k) + dh dt_k) = sum_j K_j dG.col(j) + H dh,
//     K_j = sum_k C_LB(k) dth_raw_j(k),   H = sum_k C_LB(k) dt_k,
// with C_LB(k) the attitude at sample k (mid-interval). C_LB_end(p) = Exp(dpsi_L) C_LB_end(p0).
#pragma once

#include <array>
#include <span>

#include "calib/indirect/indirect_params.h"
#include "nav/imu_sample.h"

namespace imubench::calib::indirect {

struct RunPreintegration {
  Mat3 C_LB_end0 = Mat3::Identity();  // navigated end attitude at the linearisation point
  std::array<Mat3, 3> K{Mat3::Zero(), Mat3::Zero(), Mat3::Zero()};
  Mat3 H = Mat3::Zero();
  Mat3 G0 = Mat3::Identity();  // compensation at the linearisation point
  Vec3 h0 = Vec3::Zero();
  double duration_s = 0.0;  // integrated span
  int samples = 0;
};

// Navigates `samples` (consecutive, the first interval starting at t_start) from C_LB_start
// with the gyro block `gyro` (kTriadSize doubles) and the Earth rate w_ie_L.
RunPreintegration preintegrateRun(std::span<const nav::ImuSample> samples, double t_start,
                                  const Mat3& C_LB_start, const double* gyro, const Vec3& w_ie_L);

}  // namespace imubench::calib::indirect
