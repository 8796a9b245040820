// WGS-84 Earth model pinned to published values (NIMA TR8350.2, table 3.4 / 3.5).
#include "nav/earth.h"

#include <gtest/gtest.h>

#include <cmath>

#include "nav/strapdown.h"

namespace imubench::nav {
namespace {

// Published WGS-84 normal gravity at the ellipsoid, m/s^2.
constexpr double kGammaEquator = 9.7803253359;
constexpr double kGammaPole = 9.8321849378;

// Somigliana's formula at 45 deg computed here from the published defining and derived
// constants (not from nav/earth.h): gamma = gamma_e (1 + k s2) / sqrt(1 - e2 s2), s2 = 1/2.
double somigliana45() {
  const double gamma_e = 9.7803253359;
  const double k = 0.00193185265241;   // Somigliana's constant
  const double e2 = 0.00669437999014;  // first eccentricity squared
  return gamma_e * (1.0 + k * 0.5) / std::sqrt(1.0 - e2 * 0.5);
}

TEST(Wgs84, NormalGravityAtEquatorPoleAnd45Degrees) {
  EXPECT_NEAR(normalGravity(0.0, 0.0), kGammaEquator, 1e-10);
  EXPECT_NEAR(normalGravity(0.5 * kPi, 0.0), kGammaPole, 1e-9);
  EXPECT_NEAR(somigliana45(), 9.806197769373, 1e-11);  // the hand computation itself
  EXPECT_NEAR(normalGravity(0.25 * kPi, 0.0), somigliana45(), 1e-10);
}

TEST(Wgs84, EarthRateIsThePublishedValue) {
  EXPECT_EQ(kEarthRate, 7.292115e-5);
  const double lat = 0.3;
  const Vec3 w = earthRateL(lat);
  EXPECT_DOUBLE_EQ(w.x(), 0.0);
  EXPECT_NEAR(w.y(), 7.292115e-5 * std::cos(lat), 1e-20);
  EXPECT_NEAR(w.z(), 7.292115e-5 * std::sin(lat), 1e-20);
}

TEST(Wgs84, HeightCorrectionIsTheFreeAirGradient) {
  // Near the surface dg/dh = -2 g / a (1 + f + m - 2 f s2): about -3.086e-6 s^-2 at the equator.
  const double dg = normalGravity(0.0, 100.0) - normalGravity(0.0, 0.0);
  EXPECT_NEAR(dg / 100.0, -3.0877e-6, 2e-9);
}

TEST(Wgs84, RadiiOfCurvatureAtEquatorAndPole) {
  // R_M(0) = a (1 - e2) = 6335439.327 m; R_N(0) = a; at the pole both are a / sqrt(1 - e2).
  const Radii eq = radiiOfCurvature(0.0);
  EXPECT_NEAR(eq.meridian, 6335439.327, 1e-3);
  EXPECT_NEAR(eq.prime_vertical, 6378137.0, 1e-6);
  const Radii pole = radiiOfCurvature(0.5 * kPi);
  EXPECT_NEAR(pole.meridian, 6399593.626, 1e-3);
  EXPECT_NEAR(pole.prime_vertical, 6399593.626, 1e-3);
}

TEST(Wgs84, StrapdownUsesTheSameEarthTerms) {
  // One Earth model: the terms the mechanization uses are the published functions' values.
  const double lat = 0.9, h = 250.0;
  const EarthTerms e = earthTerms(lat, h);
  EXPECT_EQ(e.g, normalGravity(lat, h));
  EXPECT_EQ(e.radii.meridian, radiiOfCurvature(lat).meridian);
  EXPECT_EQ(earthTerms(lat, h, 9.81).g, 9.81);
}

}  // namespace
}  // namespace imubench::nav
