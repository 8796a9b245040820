// Strapdown inertial mechanization in the local level frame L = ENU (KF-GINS style).
//
// One pure step, insMech(), takes the navigation state at the start of an IMU interval and the
// increments of that interval (plus the previous interval's, for the coning and sculling
// corrections) and returns the state at its end. No allocation, no I/O.
//
// Algorithm (per interval k of length dt = imu_cur.t - prev.t):
//   Earth/transport terms at the start position and velocity:
//     w_IE_L = (0, W cos(lat), W sin(lat)),
//     w_EL_L = (-v_N / (R_M + h), v_E / (R_N + h), v_E tan(lat) / (R_N + h)),
//     zeta   = (w_IE_L + w_EL_L) dt  (rotation of L w.r.t. inertial space over the interval).
//   Attitude:   phi = dth_k + (1/12) dth_{k-1} x dth_k      (two-sample coning correction)
//               q_BtoL(k) = q(-zeta) * q_BtoL(k-1) * q(phi),  q(.) the exact rotation-vector
//               quaternion (quatFromRotationVector), so large per-sample angles stay exact.
//   Velocity:   dv_B = dv_k + a1 dth_k x dv_k + a2 dth_k x (dth_k x dv_k)   (rotation
//                      compensation, Savage's exact form for a constant rate over the
//                      interval: a1 = (1 - cos th)/th^2 ~ 1/2, a2 = (1 - sin th/th)/th^2 ~ 1/6;
//                      the second-order term matters for large per-sample angles)
//                      + (1/12)(dth_{k-1} x dv_k + dv_{k-1} x dth_k)   (sculling)
//               v_L(k) = v_L(k-1) + (I - 0.5 [zeta x]) C_LB(k-1) dv_B
//                        + (g_L - (2 w_IE_L + w_EL_L) x v_L(k-1)) dt
//   Position:   trapezoidal velocity v_m; lat += v_m,N dt / (R_M + h),
//               lon += v_m,E dt / ((R_N + h) cos lat).
// Gravity: WGS-84 normal gravity (nav/earth.h) at the interval's start position, or the
// given site gravity (then constant). Cost: one sincos, one sqrt, two rotation-vector
// quaternions per step (~100 ns; bench/nav), so no caching is needed.
#pragma once

#include <optional>
#include <string>

#include "nav/earth.h"
#include "nav/imu_sample.h"
#include "nav/rotation.h"

namespace imubench::nav {

// Navigation solution at time t. Position is geodetic (WGS-84).
struct NavState {
  double t = 0.0;                  // s
  Quat q_BtoL = Quat::Identity();  // attitude, L = ENU at the current position
  Vec3 v_L = Vec3::Zero();         // velocity w.r.t. Earth, ENU, m/s
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double height_m = 0.0;
};

// How the vertical channel is integrated.
enum class VerticalChannel {
  kHoldHeight,  // height stays at its initial value and v_U is forced to zero (a bench)
  kFree,        // free-inertial height (diverges exponentially, time constant ~ 10 min)
};

struct MechOptions {
  // Two-sample coning correction of the attitude increment: removes the drift that
  // non-commuting rotations (vibration, coning) cause between samples.
  bool coning_compensation = true;
  // Sculling correction of the velocity increment: same for rotation x acceleration
  // (the rotation compensation a1 dth x dv + a2 dth x (dth x dv) is always applied: it is
  // part of the velocity update, not a refinement). Turning it off is for studies only.
  bool sculling_compensation = true;
  // Default: hold height. A bench never moves vertically, and the free-inertial vertical
  // channel is unstable, so its divergence would only add noise to the horizontal solution.
  VerticalChannel vertical = VerticalChannel::kHoldHeight;
  // Measured gravity magnitude at the site (m/s^2), e.g. a recording's gravity_mps2. Empty:
  // WGS-84 normal gravity at the current latitude and height.
  std::optional<double> gravity_mps2;

  bool IsValid(std::string* why) const;
};

// One mechanization step. Preconditions (the caller checks; our bug otherwise): imu_cur.t >
// prev.t; imu_prev holds the interval that ended at prev.t (zero increments for the very
// first interval, which disables coning/sculling for it); options valid.
NavState insMech(const NavState& prev, const ImuSample& imu_prev, const ImuSample& imu_cur,
                 const MechOptions& opt);

// Default options with the site's measured gravity, if it has one (a recording's
// gravity_mps2): keeps the mechanization's gravity consistent with the site.
inline MechOptions mechOptionsForSite(const Site& site) {
  MechOptions opt;
  opt.gravity_mps2 = site.gravity_mps2;
  return opt;
}

// Convenience: state at rest at a site, position (lat, lon = 0, height) from the site.
NavState stationaryState(double t, const Quat& q_BtoL, const Site& site);

}  // namespace imubench::nav
