// Bench physics, once, templated on the scalar: what the IMU senses on the table at one
// instant, from the table's kinematics (calib/model/table_chain.h) and the site.
//
// The intersection of the table axes is fixed on the Earth, so at that point
//   f_B    = C_LB^T (0, 0, g)              specific force (normal gravity includes the
//                                          centrifugal term; L is ENU, z Up)
//   w_IB_B = C_LB^T w_ie_L + w_LB_B         angular rate of B w.r.t. inertial space
// and at a sensing point r (m, frame B) relative to that intersection the specific force adds
// the lever-arm term  wdot x r + w x (w x r),  w = w_LB_B.
#pragma once

#include "calib/model/table_chain.h"

namespace imubench::calib::model {

template <typename T>
struct Physics {
  Vec3T<T> f_B = Vec3T<T>::Zero();        // specific force at the axes' intersection, m/s^2
  Vec3T<T> w_IB_B = Vec3T<T>::Zero();     // inertial angular rate, rad/s
  Vec3T<T> w_LB_B = Vec3T<T>::Zero();     // table angular rate, rad/s
  Vec3T<T> wdot_LB_B = Vec3T<T>::Zero();  // its derivative, rad/s^2
};

// Physics at the intersection of the axes for gravity g (m/s^2) and Earth rate w_ie_L (L).
template <typename T>
Physics<T> benchPhysics(const ChainKinematics<T>& k, const T& gravity, const Vec3T<T>& w_ie_L) {
  const T zero(0.0);
  Physics<T> p;
  const Mat3T<T> C_BL = k.C_LB.transpose();
  p.f_B = C_BL * Vec3T<T>(zero, zero, gravity);
  p.w_IB_B = C_BL * w_ie_L + k.w_LB_B;
  p.w_LB_B = k.w_LB_B;
  p.wdot_LB_B = k.wdot_LB_B;
  return p;
}

// Specific-force term of a sensing point r (m, B) off the axes' intersection, for the table
// rate w = w_LB_B and its derivative wdot (B).
template <typename T>
Vec3T<T> leverArmTerm(const Vec3T<T>& w, const Vec3T<T>& wdot, const Vec3T<T>& r) {
  return wdot.cross(r) + w.cross(w.cross(r));
}

// Specific force sensed at the point r (m, B).
template <typename T>
Vec3T<T> specificForceAt(const Physics<T>& p, const Vec3T<T>& r) {
  return p.f_B + leverArmTerm(p.w_LB_B, p.wdot_LB_B, r);
}

}  // namespace imubench::calib::model
