// What the two static-hold costs of the navigation-based calibration share
// (indirect_static_accel_cost.h, indirect_static_gyro_cost.h): the triad's mean reading over the
// hold, the table setting (geometry, encoder angles), and the residual's Ceres shape (three
// residuals of the triad block and the table block of indirect_params.h).
#pragma once

#include <ceres/ceres.h>

#include "calib/indirect/indirect_params.h"

namespace imubench::calib::indirect {

template <class Cost>
class StaticHoldCost {
 public:
  // The auto-differentiated cost; args are Cost's constructor arguments.
  template <class... Args>
  static ceres::CostFunction* Create(const Args&... args) {
    return new ceres::AutoDiffCostFunction<Cost, 3, kTriadSize, kTableSize>(new Cost(args...));
  }

 protected:
  StaticHoldCost(const Vec3& reading_mean, const TableGeometry& geometry, const TableAngles& angles)
      : reading_(reading_mean), geometry_(geometry), angles_(angles) {}

  // The compensated mean reading for the triad block, and C_LP for the table block.
  template <typename T>
  Vec3T<T> compensated(const T* triad) const {
    return compensate(triad, reading_);
  }
  template <typename T>
  Mat3T<T> attitude(const T* table) const {
    return platformAttitude(geometry_, angles_, table);
  }

 private:
  Vec3 reading_;
  TableGeometry geometry_;
  TableAngles angles_;
};

}  // namespace imubench::calib::indirect
