#include "nav/earth.h"

#include <cmath>

namespace imubench::nav {

double normalGravity(double latitude_rad, double height_m) {
  using namespace wgs84;
  const double s2 = std::sin(latitude_rad) * std::sin(latitude_rad);
  const double g0 = kGammaE * (1.0 + kK * s2) / std::sqrt(1.0 - kE2 * s2);
  const double h = height_m;
  return g0 * (1.0 - 2.0 / kA * (1.0 + kF + kM - 2.0 * kF * s2) * h + 3.0 * h * h / (kA * kA));
}

double siteGravity(const Site& site) {
  return site.gravity_mps2 ? *site.gravity_mps2 : normalGravity(site.latitude_rad, site.height_m);
}

Radii radiiOfCurvature(double latitude_rad) {
  using namespace wgs84;
  const double s2 = std::sin(latitude_rad) * std::sin(latitude_rad);
  const double w = std::sqrt(1.0 - kE2 * s2);
  return {kA * (1.0 - kE2) / (w * w * w), kA / w};
}

}  // namespace imubench::nav
