#include "calib/table_model.h"

#include <cmath>

namespace imubench::calib {
namespace {

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

// Both blocks list their entries in offset order (checked here).
static_assert(model::kTiltX == 0 && model::kTiltY == 1 && model::kNonorthInnerY == 2 &&
              model::kNonorthMiddleX == 3 && model::kNonorthMiddleY == 4);
static_assert(model::kMountX == 0 && model::kMountY == 1 && model::kZeroOuter == 2 &&
              model::kZeroMiddle == 3 && model::kZeroInner == 4);

std::array<double, model::kTableAxesSize> axesBlock(const TableErrors& e) {
  const Nonorthogonality& nu = e.nonorthogonality;
  return {e.base_tilt.x(), e.base_tilt.y(), nu.inner_y, nu.middle_x, nu.middle_y};
}

std::array<double, model::kTableDeviceSize> deviceBlock(const TableErrors& e) {
  const EncoderZero& z = e.encoder_zero;
  return {e.mounting.x(), e.mounting.y(), z.outer, z.middle, z.inner};
}

model::ChainErrors<double> chainErrors(TableKind kind, const TableErrors& e) {
  const auto axes = axesBlock(e);
  const auto device = deviceBlock(e);
  return model::chainErrors(kind, axes.data(), device.data());
}

TableModel::TableModel(const TableGeometry& geometry, const TableErrors& errors,
                       const ChainOptions& options)
    : geometry_(geometry),
      errors_(errors),
      options_(options),
      chain_errors_(chainErrors(geometry.kind, errors)),
      factors_(model::chainFactors(geometry.kind, geometry.outer_axis_heading_rad, chain_errors_,
                                   options.first_order_errors)) {}

Mat3 TableModel::C_LB(const TableAngles& a) const {
  const model::ChainErrors<double>& e = chain_errors_;
  return model::chainAttitude(factors_, a.outer + e.zero_outer, a.middle + e.zero_middle,
                              a.inner + e.zero_inner);
}

// flatten: chainKinematics' rotation helpers inlined for double (issue 31).
[[gnu::flatten]] TableKinematics TableModel::kinematics(const TableState& s) const {
  const model::ChainErrors<double>& e = chain_errors_;
  auto joint = [](const AxisState& a, double zero) {
    return model::JointState<double>{a.angle + zero, a.rate, a.accel};
  };
  TableKinematics k =
      model::chainKinematics(factors_, joint(s.outer, e.zero_outer), joint(s.middle, e.zero_middle),
                             joint(s.inner, e.zero_inner));
  if (options_.first_order_errors) k.C_LB = C_LB(s.angles());
  return k;
}

Mat3 TableModel::nominalC_LB(const TableAngles& a) const {
  if (geometry_.kind == TableKind::kTwoAxis) {
    return model::headingRotation(geometry_.kind, geometry_.outer_axis_heading_rad) * Rx(a.outer) *
           Rz(a.inner);
  }
  return Rz(a.outer) * Rx(a.middle) * Rz(a.inner);
}

TableInverse TableModel::inverse(const Mat3& C) const {
  TableInverse r;
  if (!C.allFinite()) return r;
  if (geometry_.kind == TableKind::kTwoAxis) {
    // H^T C = Rx(a) Rz(b): third column (0, -sin a, cos a) fixes a, then Rz(b) = Rx(-a) H^T C.
    const Mat3 c =
        model::headingRotation(geometry_.kind, geometry_.outer_axis_heading_rad).transpose() * C;
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
