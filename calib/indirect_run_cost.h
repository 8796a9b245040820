// Cost of one rotation run (navigation-based calibration, the seed's 12-run residual).
//
// The navigation solution starts at rest from the table setting, turns with the run and stops.
// At the end it resolves the specific force f_B = C_LP_end^T (0, 0, g) of the hold after the
// run into L with its own attitude C_LB_nav(p). The horizontal components of
//     f_L = C_LB_nav(p) C_LP_end^T (0, 0, g)
// are the change of the horizontal apparent acceleration over the run (the start hold's
// horizontal components are the static residuals). Divided by g they are the attitude
// mismatch about the horizontal axes, weighted by the gyro angle random walk over the run.
// The base tilt multiplies both the start and the end attitude and cancels here.
// C_LB_nav(p) = Exp(dpsi_L(p)) C_LB_end0 from calib/indirect_preintegration.h.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calib/indirect_params.h"
#include "calib/indirect_preintegration.h"

namespace imubench::calib::indirect {

class RunCost {
 public:
  // sigma_angle: standard deviation of the navigated end attitude about a horizontal axis
  // from gyro noise (rad).
  RunCost(const RunPreintegration& pre, const Mat3& C_LP_end, double sigma_angle)
      : pre_(pre), u_(pre.C_LB_end0 * C_LP_end.transpose() * Vec3::UnitZ()), sigma_(sigma_angle) {}

  template <typename T>
  bool operator()(const T* gyro, T* residual) const {
    Mat3T<T> G;
    Vec3T<T> h;
    compensationAffine(gyro, &G, &h);
    const Mat3T<T> dG = G - pre_.G0.cast<T>();
    Vec3T<T> dpsi = pre_.H.cast<T>() * (h - pre_.h0.cast<T>());
    for (int j = 0; j < 3; ++j) dpsi += pre_.K[j].cast<T>() * dG.col(j);
    const Vec3T<T> u = u_.cast<T>();
    T u_rot[3];
    const T u_in[3] = {u.x(), u.y(), u.z()};
    const T aa[3] = {dpsi.x(), dpsi.y(), dpsi.z()};
    ceres::AngleAxisRotatePoint(aa, u_in, u_rot);
    residual[0] = u_rot[0] / sigma_;
    residual[1] = u_rot[1] / sigma_;
    return true;
  }

  static ceres::CostFunction* Create(const RunPreintegration& pre, const Mat3& C_LP_end,
                                     double sigma_angle) {
    return new ceres::AutoDiffCostFunction<RunCost, 2, kTriadSize>(
        new RunCost(pre, C_LP_end, sigma_angle));
  }

 private:
  RunPreintegration pre_;
  Vec3 u_;  // unit vertical of the end hold as the navigation at p0 resolves it in L
  double sigma_;
};

}  // namespace imubench::calib::indirect
