// Cost of one static hold for the accelerometer triad (navigation-based calibration).
//
// The navigation solution starts from the table setting, so at rest the specific force it
// resolves in L is  f_L = C_LP(angles, theta, nu) f_P,  with C_LP the platform attitude of
// indirect_params.h (encoder angles, base tilt theta, nonorthogonality nu) and f_P the
// compensated accelerometer mean. A perfect model gives f_L = (0, 0, g). The horizontal components
// are the seed's "horizontal apparent acceleration" at the start/end of each run; the vertical one
// fixes the scale factors.
#pragma once

#include "calib/indirect/indirect_static_hold.h"

namespace imubench::calib::indirect {

class StaticAccelCost : public StaticHoldCost<StaticAccelCost> {
 public:
  // reading_mean: mean accelerometer reading over the hold (m/s^2); C_LP: nominal attitude;
  // gravity: site gravity (m/s^2); sigma: standard deviation of each mean component (m/s^2,
  // body axes).
  StaticAccelCost(const Vec3& reading_mean, const TableGeometry& geometry,
                  const TableAngles& angles, double gravity, const Vec3& sigma)
      : StaticHoldCost(reading_mean, geometry, angles),
        gravity_(gravity),
        sigma_(sigmaInL(geometry, angles, sigma)) {}

  // The residual is in L, the sigmas of the mean are per body axis: each L component's sigma
  // from the nominal attitude, sigma_L(i)^2 = sum_j C_LP(i, j)^2 sigma_B(j)^2 (a body axis'
  // noise lands on the L axis it points along; unequal axes, e.g. quantised readings near
  // zero, would otherwise whiten the vertical residual with a horizontal axis' sigma).
  static Vec3 sigmaInL(const TableGeometry& geometry, const TableAngles& angles,
                       const Vec3& sigma_B) {
    const double zero[kTableSize] = {};
    const Mat3 C = platformAttitude(geometry, angles, zero);
    return (C.cwiseAbs2() * sigma_B.cwiseAbs2()).cwiseSqrt();
  }

  template <typename T>
  bool operator()(const T* accel, const T* table, T* residual) const {
    const Vec3T<T> f_P = compensated(accel);
    const Vec3T<T> f_L = attitude(table) * f_P;
    residual[0] = f_L.x() / sigma_.x();
    residual[1] = f_L.y() / sigma_.y();
    residual[2] = (f_L.z() - gravity_) / sigma_.z();
    return true;
  }

 private:
  double gravity_;
  Vec3 sigma_;
};

}  // namespace imubench::calib::indirect
