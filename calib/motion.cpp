#include "calib/motion.h"

#include <algorithm>

namespace imubench::calib {

AxisState AxisTrajectory::at(double t) const {
  if (phases_.empty()) return {};
  auto it = std::upper_bound(phases_.begin(), phases_.end(), t,
                             [](double tt, const AxisPhase& p) { return tt < p.t0; });
  if (it == phases_.begin()) return {phases_.front().angle0, 0.0, 0.0};
  return stateIn(*(it - 1), t);
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
