// One IMU output sample: increments over the interval (t - dt, t].
#pragma once

#include <limits>
#include <vector>

#include "nav/rotation.h"

namespace imubench::nav {

struct ImuSample {
  double t = 0.0;              // s, END of the sample interval (interchange.md)
  Vec3 dtheta = Vec3::Zero();  // rad, integral of the gyro reading over the interval, frame B
  Vec3 dvel = Vec3::Zero();    // m/s, integral of the accelerometer reading, frame B
  double temp_c = std::numeric_limits<double>::quiet_NaN();  // degC; NaN when not reported
};

using ImuSamples = std::vector<ImuSample>;

}  // namespace imubench::nav
