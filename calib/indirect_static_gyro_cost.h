// Cost of one static hold for the gyro triad (navigation-based calibration): at rest the
// compensated gyro mean must equal the Earth rate resolved in P through the table setting,
//   w_P = C_LP^T (I - [theta x]) w_ie_L.
// This fixes the gyro biases (the rotations see them only weakly).
#pragma once

#include <ceres/ceres.h>

#include "calib/indirect_params.h"

namespace imubench::calib::indirect {

class StaticGyroCost {
 public:
  // reading_mean: mean gyro reading over the hold (rad/s); sigma: standard deviation of each
  // mean component (rad/s).
  StaticGyroCost(const Vec3& reading_mean, const Mat3& C_LP, const Vec3& w_ie_L, const Vec3& sigma)
      : reading_(reading_mean), C_LP_(C_LP), w_ie_L_(w_ie_L), sigma_(sigma) {}

  template <typename T>
  bool operator()(const T* gyro, const T* table, T* residual) const {
    const Vec3T<T> w_P = compensate(gyro, reading_);
    const Vec3T<T> theta(table[kTiltX], table[kTiltY], T(0.0));
    const Vec3T<T> w_L = w_ie_L_.cast<T>();
    const Vec3T<T> expected = C_LP_.transpose().cast<T>() * (w_L - theta.cross(w_L));
    for (int i = 0; i < 3; ++i) residual[i] = (w_P[i] - expected[i]) / sigma_[i];
    return true;
  }

  static ceres::CostFunction* Create(const Vec3& reading_mean, const Mat3& C_LP, const Vec3& w_ie_L,
                                     const Vec3& sigma) {
    return new ceres::AutoDiffCostFunction<StaticGyroCost, 3, kTriadSize, kTableSize>(
        new StaticGyroCost(reading_mean, C_LP, w_ie_L, sigma));
  }

 private:
  Vec3 reading_;
  Mat3 C_LP_;
  Vec3 w_ie_L_;
  Vec3 sigma_;
};

}  // namespace imubench::calib::indirect
