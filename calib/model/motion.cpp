#include "calib/model/motion.h"

#include <algorithm>

#include "calib/model/motion_profile.h"

namespace imubench::calib {

AxisState AxisTrajectory::at(double t) const {
  return model::profileSample(phases_, t);
}

double Motion::temperatureAt(double t) const {
  if (temperature.empty()) return 20.0;
  if (t <= temperature.front().t) return temperature.front().temp_c;
  if (t >= temperature.back().t) return temperature.back().temp_c;
  auto it = std::upper_bound(temperature.begin(), temperature.end(), t,
                             [](double tt, const TemperatureKnot& k) { return tt < k.t; });
  const TemperatureKnot& b = *it;
  const TemperatureKnot& a = *(it - 1);
  const double w = (b.t > a.t) ? (t - a.t) / (b.t - a.t) : 1.0;
  return a.temp_c + w * (b.temp_c - a.temp_c);
}

}  // namespace imubench::calib
