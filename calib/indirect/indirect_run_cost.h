// Cost of one rotation run (navigation-based calibration, the seed's 12-run residual).
//
// The navigation solution starts at rest from the table setting C_LP_start, turns with the run
// and stops. At the end it resolves the specific force f_B = C_LP_end^T (0, 0, g) of the hold
// after the run into L with its own attitude C_LB_nav(p). The horizontal components of
//     f_L = C_LB_nav(p) C_LP_end^T (0, 0, g)
// are the change of the horizontal apparent acceleration over the run (the start hold's
// horizontal components are the static residuals). Divided by g they are the attitude
// mismatch about the horizontal axes, weighted by the gyro angle random walk over the run.
//
// Dependence on the parameters p = (gyro block, table block):
//   C_LB_nav(p) = Exp(dpsi_L(gyro)) [C_LP_start(table) C_LP_start(table0)^T] C_LB_end0,
// with C_LB_end0 navigated from C_LP_start(table0) at the linearisation point
// (calib/indirect/indirect_preintegration.h): a change of the start setting rotates the whole
// navigated path in L (the Earth-rate transport over a run is ~1e-3 rad, so the commutator is
// negligible). The base tilt enters start and end alike and cancels to first order; the
// nonorthogonality does not (the start and end settings differ by a turn about a table axis).
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calib/indirect/indirect_params.h"
#include "calib/indirect/indirect_preintegration.h"

namespace imubench::calib::indirect {

class RunCost {
 public:
  // C_LP_start0: the start setting the preintegration used; sigma_angle: standard deviation
  // of the navigated end attitude about a horizontal axis from gyro noise (rad).
  RunCost(const RunPreintegration& pre, const TableGeometry& geometry, const TableAngles& start,
          const TableAngles& end, const Mat3& C_LP_start0, double sigma_angle)
      : pre_(pre),
        geometry_(geometry),
        start_(start),
        end_(end),
        nav_from_start0_(C_LP_start0.transpose() * pre.C_LB_end0),
        sigma_(sigma_angle) {}

  template <typename T>
  bool operator()(const T* gyro, const T* table, T* residual) const {
    Mat3T<T> G;
    Vec3T<T> h;
    compensationAffine(gyro, &G, &h);
    const Mat3T<T> dG = G - pre_.G0.cast<T>();
    Vec3T<T> dpsi = pre_.H.cast<T>() * (h - pre_.h0.cast<T>());
    for (int j = 0; j < 3; ++j) dpsi += pre_.K[j].cast<T>() * dG.col(j);
    // Unit vertical of the end hold as the navigation (before the gyro correction) resolves it.
    const Vec3T<T> u = platformAttitude(geometry_, start_, table) * nav_from_start0_.cast<T>() *
                       platformAttitude(geometry_, end_, table).transpose() *
                       Vec3::UnitZ().cast<T>();
    T u_rot[3];
    const T u_in[3] = {u.x(), u.y(), u.z()};
    const T aa[3] = {dpsi.x(), dpsi.y(), dpsi.z()};
    ceres::AngleAxisRotatePoint(aa, u_in, u_rot);
    residual[0] = u_rot[0] / sigma_;
    residual[1] = u_rot[1] / sigma_;
    return true;
  }

  static ceres::CostFunction* Create(const RunPreintegration& pre, const TableGeometry& geometry,
                                     const TableAngles& start, const TableAngles& end,
                                     const Mat3& C_LP_start0, double sigma_angle) {
    return new ceres::AutoDiffCostFunction<RunCost, 2, kTriadSize, kTableSize>(
        new RunCost(pre, geometry, start, end, C_LP_start0, sigma_angle));
  }

 private:
  RunPreintegration pre_;
  TableGeometry geometry_;
  TableAngles start_;
  TableAngles end_;
  Mat3 nav_from_start0_;  // C_LP_start0^T C_LB_end0: the run's body turn (and Earth transport)
  double sigma_;
};

}  // namespace imubench::calib::indirect
