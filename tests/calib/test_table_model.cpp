#include <gtest/gtest.h>

#include "calib/table_model.h"

namespace imubench::calib {
namespace {

constexpr double kAs = kArcsecToRad;

Vec3 vee(const Mat3& s) {
  return {s(2, 1), s(0, 2), s(1, 0)};
}

TableErrors someErrors() {
  TableErrors e;
  e.base_tilt = Vec2(20 * kAs, -35 * kAs);
  e.nonorthogonality = {15 * kAs, -25 * kAs, 40 * kAs};
  e.mounting = Vec2(-30 * kAs, 12 * kAs);
  e.encoder_zero = {10 * kAs, -20 * kAs, 30 * kAs};
  return e;
}

TEST(TableModel, NominalTwoAxisMatchesInterchange) {
  const TableModel t;  // two-axis, heading East, no errors
  EXPECT_LT((t.C_LB({}) - Mat3::Identity()).norm(), 1e-15);
  const TableAngles a{0.3, 0.0, -1.1};
  EXPECT_LT((t.C_LB(a) - Rx(0.3) * Rz(-1.1)).norm(), 1e-15);
}

TEST(TableModel, HeadingNorthTurnsTheOuterAxisToNorth) {
  const TableModel t(TableGeometry{TableKind::kTwoAxis, 0.0}, TableErrors{});
  // The outer axis (body x at zero angles) must point North, and an outer rotation must
  // leave the North axis fixed.
  const Mat3 c0 = t.C_LB({});
  EXPECT_LT((c0 * Vec3::UnitX() - Vec3::UnitY()).norm(), 1e-15);
  const Mat3 c = t.C_LB({0.7, 0.0, 0.0});
  EXPECT_LT((c * c0.transpose() * Vec3::UnitY() - Vec3::UnitY()).norm(), 1e-15);
}

TEST(TableModel, NominalThreeAxisMatchesInterchange) {
  const TableModel t(TableGeometry{TableKind::kThreeAxis}, TableErrors{});
  const TableAngles a{0.4, -0.9, 2.0};
  EXPECT_LT((t.C_LB(a) - Rz(0.4) * Rx(-0.9) * Rz(2.0)).norm(), 1e-15);
}

// The literal interchange chain with first-order factors.
Mat3 literalChain(TableKind kind, const TableErrors& e, const TableAngles& a) {
  const Mat3 I = Mat3::Identity();
  const Mat3 th = I + skew(Vec3(e.base_tilt.x(), e.base_tilt.y(), 0));
  const Mat3 mu = I + skew(Vec3(e.mounting.x(), e.mounting.y(), 0));
  const EncoderZero& z = e.encoder_zero;
  if (kind == TableKind::kTwoAxis) {
    const Mat3 nu = I + skew(Vec3(0, e.nonorthogonality.inner_y, 0));
    return th * Rx(a.outer + z.outer) * nu * Rz(a.inner + z.inner) * mu;
  }
  const Mat3 nu1 = I + skew(Vec3(e.nonorthogonality.middle_x, e.nonorthogonality.middle_y, 0));
  const Mat3 nu2 = I + skew(Vec3(0, e.nonorthogonality.inner_y, 0));
  return th * Rz(a.outer + z.outer) * nu1 * Rx(a.middle + z.middle) * nu2 * Rz(a.inner + z.inner) *
         mu;
}

TEST(TableModel, ErrorChainsEqualInterchangeToFirstOrder) {
  const TableErrors e = someErrors();
  const TableAngles a{0.8, -0.3, 2.4};
  for (TableKind kind : {TableKind::kTwoAxis, TableKind::kThreeAxis}) {
    const TableModel exact(TableGeometry{kind}, e);
    const TableModel literal(TableGeometry{kind}, e, ChainOptions{true});
    const Mat3 ref = literalChain(kind, e, a);
    EXPECT_LT((literal.C_LB(a) - ref).norm(), 1e-15);
    // Exact rotations differ at second order only: |t|^2 ~ (60 arcsec)^2 ~ 1e-7.
    const double diff = (exact.C_LB(a) - ref).norm();
    EXPECT_LT(diff, 2e-7);
    EXPECT_GT(diff, 0.0);
    // And orthonormal.
    EXPECT_LT((exact.C_LB(a).transpose() * exact.C_LB(a) - Mat3::Identity()).norm(), 1e-15);
  }
}

TEST(TableModel, SmallErrorsArePerturbationsAtZeroAngles) {
  // At zero angles (heading East) the two-axis chain is I + [theta + nu + mu + encoder zeros]
  // to first order.
  const TableErrors e = someErrors();
  const TableModel t(TableGeometry{}, e);
  const Vec3 expected(e.base_tilt.x() + e.mounting.x() + e.encoder_zero.outer,
                      e.base_tilt.y() + e.nonorthogonality.inner_y + e.mounting.y(),
                      e.encoder_zero.inner);
  const Vec3 got = vee(t.C_LB({}) - Mat3::Identity());
  EXPECT_LT((got - expected).norm(), 5e-7);  // second order: (1e-4 rad)^2 scale
}

void checkDerivatives(TableKind kind) {
  const TableModel t(TableGeometry{kind, 1.2}, someErrors());
  TableState s;
  s.outer = {0.7, 0.35, -0.2};
  s.middle = {-0.4, -0.6, 0.5};
  s.inner = {1.9, 1.1, 0.3};
  auto at = [&](double dt) {
    TableState x = s;
    for (AxisState* a : {&x.outer, &x.middle, &x.inner}) {
      a->angle += a->rate * dt + 0.5 * a->accel * dt * dt;
      a->rate += a->accel * dt;
    }
    return x;
  };
  const double h = 1e-5;
  const TableKinematics k = t.kinematics(s);
  EXPECT_LT((k.C_LB - t.C_LB(s.angles())).norm(), 1e-15);
  const Mat3 dC = (t.C_LB(at(h).angles()) - t.C_LB(at(-h).angles())) / (2 * h);
  const Vec3 w_num = vee(k.C_LB.transpose() * dC);  // dC/dt = C [w x]
  EXPECT_LT((w_num - k.w_LB_B).norm(), 1e-8) << w_num.transpose() << " vs " << k.w_LB_B.transpose();
  const Vec3 wdot_num = (t.kinematics(at(h)).w_LB_B - t.kinematics(at(-h)).w_LB_B) / (2 * h);
  EXPECT_LT((wdot_num - k.wdot_LB_B).norm(), 1e-8)
      << wdot_num.transpose() << " vs " << k.wdot_LB_B.transpose();
}

TEST(TableModel, AngularRateMatchesNumericalDerivativeTwoAxis) {
  checkDerivatives(TableKind::kTwoAxis);
}
TEST(TableModel, AngularRateMatchesNumericalDerivativeThreeAxis) {
  checkDerivatives(TableKind::kThreeAxis);
}

TEST(TableModel, InverseRoundTripTwoAxis) {
  const TableModel t(TableGeometry{TableKind::kTwoAxis, 0.3}, TableErrors{});
  for (double o : {-2.5, -0.4, 0.0, 1.0, 3.0}) {
    for (double i : {-3.0, 0.0, 0.2, 2.0}) {
      const TableInverse inv = t.inverse(t.nominalC_LB({o, 0.0, i}));
      ASSERT_TRUE(inv.ok);
      EXPECT_LT(inv.residual_rad, 1e-12);
      EXPECT_LT((t.nominalC_LB(inv.angles) - t.nominalC_LB({o, 0.0, i})).norm(), 1e-12);
    }
  }
  // A rotation about L's y (North) axis is not reachable by a two-axis table heading 0.3 rad
  // in general: the inverse returns the closest angles with a non-zero residual.
  const TableInverse inv = t.inverse(Ry(0.5));
  ASSERT_TRUE(inv.ok);
  EXPECT_GT(inv.residual_rad, 1e-3);
}

TEST(TableModel, InverseRoundTripThreeAxisIncludingGimbalLock) {
  const TableModel t(TableGeometry{TableKind::kThreeAxis}, TableErrors{});
  for (double o : {-2.0, 0.5, 3.0}) {
    for (double m : {0.0, 0.3, -1.2, kPi}) {
      for (double i : {-1.0, 0.0, 2.5}) {
        const Mat3 c = t.nominalC_LB({o, m, i});
        const TableInverse inv = t.inverse(c);
        ASSERT_TRUE(inv.ok);
        EXPECT_LT(inv.residual_rad, 1e-9);
        EXPECT_LT((t.nominalC_LB(inv.angles) - c).norm(), 1e-9);
      }
    }
  }
}

TEST(TableModel, StateFromMotionMapsAxisOrder) {
  Motion m;
  m.kind = TableKind::kThreeAxis;
  m.axes.resize(3);
  m.axes[0].append({0.0, 1.0, 0.0, 0.0});
  m.axes[1].append({0.0, 2.0, 0.5, 0.0});
  m.axes[2].append({0.0, 3.0, 0.0, 0.2});
  const TableState s = tableStateAt(m, 2.0);
  EXPECT_DOUBLE_EQ(s.outer.angle, 1.0);
  EXPECT_DOUBLE_EQ(s.middle.angle, 3.0);
  EXPECT_DOUBLE_EQ(s.middle.rate, 0.5);
  EXPECT_DOUBLE_EQ(s.inner.angle, 3.4);
  EXPECT_DOUBLE_EQ(s.inner.accel, 0.2);
}

}  // namespace
}  // namespace imubench::calib
