#include "nav/strapdown.h"

#include <cassert>
#include <cmath>

namespace imubench::nav {

bool MechOptions::IsValid(std::string* why) const {
  if (gravity_mps2 && !(*gravity_mps2 > 9.0 && *gravity_mps2 < 10.5)) {
    if (why) *why = "gravity_mps2 must be an Earth-surface value in (9, 10.5) m/s^2";
    return false;
  }
  if (vertical != VerticalChannel::kHoldHeight && vertical != VerticalChannel::kFree) {
    if (why) *why = "vertical channel mode is not one of hold-height / free";
    return false;
  }
  return true;
}

NavState insMech(const NavState& prev, const ImuSample& imu_prev, const ImuSample& imu_cur,
                 const MechOptions& opt) {
  const double dt = imu_cur.t - prev.t;
  assert(dt > 0.0);

  const EarthTerms e = earthTerms(prev.lat_rad, prev.height_m, opt.gravity_mps2);
  const double rm_h = e.radii.meridian + prev.height_m;
  const double rn_h = e.radii.prime_vertical + prev.height_m;
  const Vec3& v0 = prev.v_L;
  const Vec3 w_ie_L = earthRateL(e.cos_lat, e.sin_lat);
  const Vec3 w_el_L(-v0.y() / rm_h, v0.x() / rn_h, v0.x() * e.sin_lat / (e.cos_lat * rn_h));
  const Vec3 zeta = (w_ie_L + w_el_L) * dt;

  const Vec3& dth = imu_cur.dtheta;
  const Vec3& dv = imu_cur.dvel;

  // Velocity: specific-force increment in B with rotation and sculling compensation,
  // projected with the attitude at the start of the interval and the mid-interval L frame.
  const double th2 = dth.squaredNorm();
  double a1 = 0.0;  // (1 - cos th) / th^2
  double a2 = 0.0;  // (1 - sin th / th) / th^2
  if (th2 < 1e-2) {
    a1 = 0.5 - th2 / 24.0 + th2 * th2 / 720.0;
    a2 = 1.0 / 6.0 - th2 / 120.0 + th2 * th2 / 5040.0;
  } else {
    const double th = std::sqrt(th2);
    a1 = (1.0 - std::cos(th)) / th2;
    a2 = (1.0 - std::sin(th) / th) / th2;
  }
  const Vec3 th_x_dv = dth.cross(dv);
  Vec3 dv_B = dv + a1 * th_x_dv + a2 * dth.cross(th_x_dv);
  if (opt.sculling_compensation) {
    dv_B += (imu_prev.dtheta.cross(dv) + imu_prev.dvel.cross(dth)) / 12.0;
  }
  const Vec3 dv_f_L0 = prev.q_BtoL * dv_B;
  const Vec3 dv_f_L = dv_f_L0 - 0.5 * zeta.cross(dv_f_L0);
  const Vec3 g_L(0.0, 0.0, -e.g);
  const Vec3 dv_gc_L = (g_L - (2.0 * w_ie_L + w_el_L).cross(v0)) * dt;

  NavState next;
  next.t = imu_cur.t;
  next.v_L = v0 + dv_f_L + dv_gc_L;
  if (opt.vertical == VerticalChannel::kHoldHeight) next.v_L.z() = 0.0;

  // Attitude.
  Vec3 phi = dth;
  if (opt.coning_compensation) phi += imu_prev.dtheta.cross(dth) / 12.0;
  next.q_BtoL = quatFromRotationVector(-zeta) * prev.q_BtoL * quatFromRotationVector(phi);
  next.q_BtoL.normalize();

  // Position, trapezoidal velocity. Radii at the start position (their change over one
  // interval is ~1e-9 relative even at 1 km/s).
  const Vec3 v_mid = 0.5 * (v0 + next.v_L);
  next.height_m =
      opt.vertical == VerticalChannel::kHoldHeight ? prev.height_m : prev.height_m + v_mid.z() * dt;
  next.lat_rad = prev.lat_rad + v_mid.y() * dt / rm_h;
  next.lon_rad = prev.lon_rad + v_mid.x() * dt / (rn_h * e.cos_lat);
  return next;
}

NavState stationaryState(double t, const Quat& q_BtoL, const Site& site) {
  NavState s;
  s.t = t;
  s.q_BtoL = q_BtoL.normalized();
  s.lat_rad = site.latitude_rad;
  s.height_m = site.height_m;
  return s;
}

}  // namespace imubench::nav
