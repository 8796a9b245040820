// Cost of one static hold for the gyro triad (navigation-based calibration): at rest the
// compensated gyro mean must equal the Earth rate resolved in P through the table setting,
//   w_P = C_LP(angles, theta, nu)^T w_ie_L   (platform attitude of indirect_params.h).
// This fixes the gyro biases (the rotations see them only weakly).
#pragma once

#include "calib/indirect/indirect_static_hold.h"

namespace imubench::calib::indirect {

class StaticGyroCost : public StaticHoldCost<StaticGyroCost> {
 public:
  // reading_mean: mean gyro reading over the hold (rad/s); sigma: standard deviation of each
  // mean component (rad/s).
  StaticGyroCost(const Vec3& reading_mean, const TableGeometry& geometry, const TableAngles& angles,
                 const Vec3& w_ie_L, const Vec3& sigma)
      : StaticHoldCost(reading_mean, geometry, angles), w_ie_L_(w_ie_L), sigma_(sigma) {}

  template <typename T>
  bool operator()(const T* gyro, const T* table, T* residual) const {
    const Vec3T<T> w_P = compensated(gyro);
    const Vec3T<T> expected = attitude(table).transpose() * w_ie_L_.cast<T>();
    for (int i = 0; i < 3; ++i) residual[i] = (w_P[i] - expected[i]) / sigma_[i];
    return true;
  }

 private:
  Vec3 w_ie_L_;
  Vec3 sigma_;
};

}  // namespace imubench::calib::indirect
