// WGS-84 Earth model: normal gravity, Earth rate, radii of curvature. Pure functions, SI.
#pragma once

#include <optional>

#include "nav/rotation.h"

namespace imubench::nav {

namespace wgs84 {
inline constexpr double kA = 6378137.0;            // semi-major axis, m
inline constexpr double kF = 1.0 / 298.257223563;  // flattening
inline constexpr double kE2 = kF * (2.0 - kF);     // first eccentricity squared
inline constexpr double kGammaE = 9.7803253359;    // normal gravity at equator, m/s^2
inline constexpr double kK = 0.00193185265241;     // Somigliana constant
inline constexpr double kM = 0.00344978650684;     // w^2 a^2 b / GM
}  // namespace wgs84

inline constexpr double kEarthRate = 7.292115e-5;  // rad/s (interchange.md)

// Where the bench stands. Gravity: WGS-84 normal gravity unless gravity_mps2 is given
// (a measured site value from a recording's meta.json).
struct Site {
  double latitude_rad = 0.0;
  double height_m = 0.0;
  std::optional<double> gravity_mps2;
};

// WGS-84 normal gravity magnitude (Somigliana, with the second-order height correction).
double normalGravity(double latitude_rad, double height_m);

// Gravity magnitude at the site: the given value if any, else normal gravity.
double siteGravity(const Site& site);

// Gravity vector in L (ENU): (0, 0, -g). (Normal gravity includes the centrifugal term.)
inline Vec3 gravityL(const Site& site) {
  return {0.0, 0.0, -siteGravity(site)};
}

// Earth rate resolved in L (ENU) from the latitude's cosine and sine: (0, W cos, W sin).
inline Vec3 earthRateL(double cos_lat, double sin_lat) {
  return {0.0, kEarthRate * cos_lat, kEarthRate * sin_lat};
}
inline Vec3 earthRateL(double latitude_rad) {
  return earthRateL(std::cos(latitude_rad), std::sin(latitude_rad));
}

struct Radii {
  double meridian = 0.0;        // R_M, north-south radius of curvature, m
  double prime_vertical = 0.0;  // R_N, east-west radius of curvature, m
};
Radii radiiOfCurvature(double latitude_rad);

// Every Earth term the strapdown mechanization needs at one position, from one sincos and one
// sqrt: the same formulas as normalGravity / radiiOfCurvature (which are computed by it).
struct EarthTerms {
  double sin_lat = 0.0;
  double cos_lat = 1.0;
  Radii radii;     // R_M, R_N (without the height)
  double g = 0.0;  // gravity magnitude: gravity_mps2 if given, else WGS-84 normal gravity
};
EarthTerms earthTerms(double latitude_rad, double height_m,
                      std::optional<double> gravity_mps2 = std::nullopt);

}  // namespace imubench::nav
