#include "calib/table_model.h"

#include <cmath>

namespace imubench::calib {
namespace {

// Small error rotation: exact exp([t x]) or literal I + [t x].
Mat3 smallRotation(const Vec3& t, bool first_order) {
  if (first_order) return Mat3::Identity() + skew(t);
  const double a = t.norm();
  if (a == 0.0) return Mat3::Identity();
  return Eigen::AngleAxisd(a, t / a).toRotationMatrix();
}

// Rx / Rz from precomputed sin and cos.
Mat3 rotX(double c, double s) {
  Mat3 r;
  r << 1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c;
  return r;
}
Mat3 rotZ(double c, double s) {
  Mat3 r;
  r << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return r;
}

// Rx(c, s) * m and Rz(c, s) * m without the full product (only two rows mix).
Mat3 rotXTimes(double c, double s, const Mat3& m) {
  Mat3 r;
  r.row(0) = m.row(0);
  r.row(1) = c * m.row(1) - s * m.row(2);
  r.row(2) = s * m.row(1) + c * m.row(2);
  return r;
}
Mat3 rotZTimes(double c, double s, const Mat3& m) {
  Mat3 r;
  r.row(0) = c * m.row(0) - s * m.row(1);
  r.row(1) = s * m.row(0) + c * m.row(1);
  r.row(2) = m.row(2);
  return r;
}
// a * m, skipping an identity a.
Mat3 times(const Mat3& a, bool a_identity, const Mat3& m) {
  return a_identity ? m : Mat3(a * m);
}

// Wraps to (-pi, pi].
double wrap(double a) {
  a = std::remainder(a, 2.0 * kPi);
  return a <= -kPi ? a + 2.0 * kPi : a;
}

// Rotation angle of a (nearly) orthonormal matrix.
double rotationAngle(const Mat3& r) {
  const double c = std::clamp(0.5 * (r.trace() - 1.0), -1.0, 1.0);
  const Vec3 v(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * v.norm(), c);
}

}  // namespace

TableState tableStateAt(const Motion& motion, double t) {
  TableState s;
  const auto n = motion.axes.size();
  if (motion.kind == TableKind::kTwoAxis) {
    if (n > 0) s.outer = motion.axes[0].at(t);
    if (n > 1) s.inner = motion.axes[1].at(t);
  } else {
    if (n > 0) s.outer = motion.axes[0].at(t);
    if (n > 1) s.middle = motion.axes[1].at(t);
    if (n > 2) s.inner = motion.axes[2].at(t);
  }
  return s;
}

TableAngles tableAnglesFromAxes(TableKind kind, const double* a) {
  if (kind == TableKind::kTwoAxis) return {a[0], 0.0, a[1]};
  return {a[0], a[1], a[2]};
}

TableModel::TableModel(const TableGeometry& geometry, const TableErrors& errors,
                       const ChainOptions& options)
    : geometry_(geometry), errors_(errors), options_(options) {
  const bool fo = options.first_order_errors;
  const Vec3 theta(errors.base_tilt.x(), errors.base_tilt.y(), 0.0);
  const Vec3 mu(errors.mounting.x(), errors.mounting.y(), 0.0);
  const Nonorthogonality& nu = errors.nonorthogonality;
  a3_ = smallRotation(mu, fo);
  if (geometry.kind == TableKind::kTwoAxis) {
    heading_ = Rz(kPi / 2.0 - geometry.outer_axis_heading_rad);
    a0_ = smallRotation(theta, fo) * heading_;
    a1_ = smallRotation(Vec3(0.0, nu.inner_y, 0.0), fo);
    a2_ = Mat3::Identity();
  } else {
    heading_ = Mat3::Identity();
    a0_ = smallRotation(theta, fo);
    a1_ = smallRotation(Vec3(nu.middle_x, nu.middle_y, 0.0), fo);
    a2_ = smallRotation(Vec3(0.0, nu.inner_y, 0.0), fo);
  }
  a0_identity_ = a0_ == Mat3::Identity();
  a1_identity_ = a1_ == Mat3::Identity();
  a2_identity_ = a2_ == Mat3::Identity();
  a3_identity_ = a3_ == Mat3::Identity();
}

Mat3 TableModel::C_LB(const TableAngles& a) const {
  const EncoderZero& z = errors_.encoder_zero;
  const double o = a.outer + z.outer;
  const double i = a.inner + z.inner;
  if (geometry_.kind == TableKind::kTwoAxis) {
    return a0_ * rotX(std::cos(o), std::sin(o)) * a1_ * rotZ(std::cos(i), std::sin(i)) * a3_;
  }
  const double m = a.middle + z.middle;
  return a0_ * rotZ(std::cos(o), std::sin(o)) * a1_ * rotX(std::cos(m), std::sin(m)) * a2_ *
         rotZ(std::cos(i), std::sin(i)) * a3_;
}

TableKinematics TableModel::kinematics(const TableState& s) const {
  // C_LB = A0 R1(q1) A1 R2(q2) ... Rn(qn) An. With P_k the product right of joint k, the body
  // rate is w = sum_k qdot_k u_k with u_k = P_k^T e_k, and its derivative
  // wdot = sum_k qddot_k u_k + sum_{j<k} qdot_j qdot_k (u_j x u_k).
  const EncoderZero& z = errors_.encoder_zero;
  TableKinematics k;
  const double o = s.outer.angle + z.outer;
  const double i = s.inner.angle + z.inner;
  // Joint axes resolved in B, inner to outer.
  const Vec3 u_inner = a3_.transpose().col(2);  // A3^T e_z
  const Mat3 p_inner = a3_identity_ ? rotZ(std::cos(i), std::sin(i))
                                    : rotZTimes(std::cos(i), std::sin(i), a3_);  // R_inner A3
  if (geometry_.kind == TableKind::kTwoAxis) {
    const Mat3 right_of_outer = times(a1_, a1_identity_, p_inner);  // P_outer
    const Vec3 u_outer = right_of_outer.row(0).transpose();         // P_outer^T e_x
    k.C_LB = times(a0_, a0_identity_, rotXTimes(std::cos(o), std::sin(o), right_of_outer));
    const double qo = s.outer.rate, qi = s.inner.rate;
    k.w_LB_B = qo * u_outer + qi * u_inner;
    k.wdot_LB_B =
        s.outer.accel * u_outer + s.inner.accel * u_inner + qo * qi * u_outer.cross(u_inner);
    if (options_.first_order_errors) k.C_LB = C_LB(s.angles());
    return k;
  }
  const double m = s.middle.angle + z.middle;
  const Mat3 right_of_middle = times(a2_, a2_identity_, p_inner);
  const Vec3 u_middle = right_of_middle.row(0).transpose();
  const Mat3 right_of_outer =
      times(a1_, a1_identity_, rotXTimes(std::cos(m), std::sin(m), right_of_middle));
  const Vec3 u_outer = right_of_outer.row(2).transpose();
  k.C_LB = times(a0_, a0_identity_, rotZTimes(std::cos(o), std::sin(o), right_of_outer));
  const double qo = s.outer.rate, qm = s.middle.rate, qi = s.inner.rate;
  k.w_LB_B = qo * u_outer + qm * u_middle + qi * u_inner;
  k.wdot_LB_B = s.outer.accel * u_outer + s.middle.accel * u_middle + s.inner.accel * u_inner +
                qo * qm * u_outer.cross(u_middle) + qo * qi * u_outer.cross(u_inner) +
                qm * qi * u_middle.cross(u_inner);
  if (options_.first_order_errors) k.C_LB = C_LB(s.angles());
  return k;
}

Mat3 TableModel::nominalC_LB(const TableAngles& a) const {
  if (geometry_.kind == TableKind::kTwoAxis) return heading_ * Rx(a.outer) * Rz(a.inner);
  return Rz(a.outer) * Rx(a.middle) * Rz(a.inner);
}

TableInverse TableModel::inverse(const Mat3& C) const {
  TableInverse r;
  if (!C.allFinite()) return r;
  if (geometry_.kind == TableKind::kTwoAxis) {
    // H^T C = Rx(a) Rz(b): third column (0, -sin a, cos a) fixes a, then Rz(b) = Rx(-a) H^T C.
    const Mat3 c = heading_.transpose() * C;
    r.angles.outer = wrap(std::atan2(-c(1, 2), c(2, 2)));
    const Mat3 rz = Rx(-r.angles.outer) * c;
    r.angles.inner = wrap(std::atan2(rz(1, 0) - rz(0, 1), rz(0, 0) + rz(1, 1)));
  } else {
    // Rz(a) Rx(b) Rz(c): third column (sin a sin b, -cos a sin b, cos b), third row
    // (sin b sin c, sin b cos c, cos b).
    const double sb = std::hypot(C(0, 2), C(1, 2));
    if (sb > 1e-9) {
      r.angles.outer = wrap(std::atan2(C(0, 2), -C(1, 2)));
      r.angles.middle = wrap(std::atan2(sb, C(2, 2)));
      r.angles.inner = wrap(std::atan2(C(2, 0), C(2, 1)));
    } else {
      // Gimbal lock: only outer + inner (or outer - inner) matters; put it all on inner.
      r.angles.outer = 0.0;
      r.angles.middle = C(2, 2) > 0.0 ? 0.0 : kPi;
      const Mat3 rest = Rx(-r.angles.middle) * C;
      r.angles.inner = wrap(std::atan2(rest(1, 0) - rest(0, 1), rest(0, 0) + rest(1, 1)));
    }
  }
  r.ok = true;
  r.residual_rad = rotationAngle(nominalC_LB(r.angles).transpose() * C);
  return r;
}

}  // namespace imubench::calib
