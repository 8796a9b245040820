#include "nav/earth.h"

#include <cmath>

namespace imubench::nav {

EarthTerms earthTerms(double latitude_rad, double height_m, std::optional<double> gravity_mps2) {
  using namespace wgs84;
  EarthTerms e;
  e.sin_lat = std::sin(latitude_rad);
  e.cos_lat = std::cos(latitude_rad);
  const double s2 = e.sin_lat * e.sin_lat;
  const double w2 = 1.0 - kE2 * s2;
  const double w = std::sqrt(w2);
  e.radii = {kA * (1.0 - kE2) / (w2 * w), kA / w};
  if (gravity_mps2) {
    e.g = *gravity_mps2;
  } else {
    // Somigliana's closed formula at the ellipsoid, then the second-order height correction.
    const double g0 = kGammaE * (1.0 + kK * s2) / w;
    const double h = height_m;
    e.g = g0 * (1.0 - 2.0 / kA * (1.0 + kF + kM - 2.0 * kF * s2) * h + 3.0 * h * h / (kA * kA));
  }
  return e;
}

double normalGravity(double latitude_rad, double height_m) {
  return earthTerms(latitude_rad, height_m).g;
}

double siteGravity(const Site& site) {
  return site.gravity_mps2 ? *site.gravity_mps2 : normalGravity(site.latitude_rad, site.height_m);
}

Radii radiiOfCurvature(double latitude_rad) {
  return earthTerms(latitude_rad, 0.0).radii;
}

}  // namespace imubench::nav
