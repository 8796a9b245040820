// The templated forward model (calib/model/) differentiated with ceres::Jet against central
// finite differences of the same functions in double: the sensor equation and its inverse,
// both table chains with every geometric error nonzero (attitude and kinematics), and the
// bench physics with the lever-arm effect. What the calibrators' costs and the observability
// analysis differentiate must be the derivative of what the simulator evaluates.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <vector>

#include "calib/model/bench_physics.h"
#include "calib/model/sensor_equation.h"
#include "calib/model/table_chain.h"
#include "tests/calib/derivative_check.h"

namespace imubench::calib::model {
namespace {

constexpr int kJetSize = 32;

template <class F>
void expectDerivativesAgree(const F& f, const std::vector<double>& x, double tol) {
  expectJetMatchesDifferences<kJetSize>(f, x, tol, static_cast<int>(x.size()));
}

std::vector<double> triadParams() {
  return {1.0002, 0.9997, 1.0001,                       // scale
          0.01,   -0.02,  0.015,                        // bias
          1e-3,   -2e-3,  3e-3,   -1e-3, 2e-3, -3e-3};  // misalignments
}

TEST(ModelDerivatives, SensorEquationAndItsInverse) {
  std::vector<double> x = triadParams();
  x.insert(x.end(), {0.3, -4.0, 9.0});  // input
  const auto f = [](const auto* p) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(p)>>;
    const Vec3T<T> in(p[kTriadSize], p[kTriadSize + 1], p[kTriadSize + 2]);
    std::vector<T> out;
    append(&out, reading(p, in));
    append(&out, input(p, in));  // the inverse, evaluated on the same vector as a reading
    return out;
  };
  expectDerivativesAgree(f, x, 1e-7);
}

TEST(ModelDerivatives, InverseUndoesTheReading) {
  const std::vector<double> p = triadParams();
  const Vec3 in(0.3, -4.0, 9.0);
  EXPECT_LT((input(p.data(), reading(p.data(), in)) - in).norm(), 1e-13);
}

// x = [axes block (5) | device block (5) | angles (3) | rates (3) | accelerations (3)].
std::vector<double> chainPoint() {
  const double as = kArcsecToRad;
  return {20 * as,  -35 * as, 15 * as, -25 * as, 40 * as,  // tilt x y, nonorth inner_y, mid x y
          -30 * as, 12 * as,  10 * as, -20 * as, 30 * as,  // mounting x y, zeros o m i
          0.7,      -1.1,     2.3,                         // encoder angles o m i, rad
          0.4,      -0.3,     0.9,                         // rates, rad/s
          0.2,      0.5,      -0.6};                       // accelerations, rad/s^2
}

// C_LB, w_LB_B and wdot_LB_B of a table kind as a function of x above.
auto chainFunction(TableKind kind) {
  return [kind](const auto* x) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(x)>>;
    const ChainErrors<T> e = chainErrors(kind, x, x + kTableAxesSize);
    const ChainFactors<T> f = chainFactors(kind, 1.2, e);
    const T* a = x + kTableAxesSize + kTableDeviceSize;
    const JointState<T> o{a[0] + e.zero_outer, a[3], a[6]};
    const JointState<T> m{a[1] + e.zero_middle, a[4], a[7]};
    const JointState<T> i{a[2] + e.zero_inner, a[5], a[8]};
    const ChainKinematics<T> k = chainKinematics(f, o, m, i);
    std::vector<T> out;
    append(&out, k.C_LB);
    append(&out, k.w_LB_B);
    append(&out, k.wdot_LB_B);
    // The attitude-only path must be the same chain.
    append(&out, Mat3T<T>(tableAttitude(kind, 1.2, e, a[0], a[1], a[2]) - k.C_LB));
    return out;
  };
}

TEST(ModelDerivatives, ThreeAxisChainWithAllGeometricErrors) {
  expectDerivativesAgree(chainFunction(TableKind::kThreeAxis), chainPoint(), 1e-7);
}

TEST(ModelDerivatives, TwoAxisChainWithAllGeometricErrors) {
  // A two-axis chain has no middle joint: drop its parameters from x.
  std::vector<double> x = chainPoint();
  const auto f3 = chainFunction(TableKind::kTwoAxis);
  const std::vector<int> unused = {
      kNonorthMiddleX, kNonorthMiddleY, kTableAxesSize + kZeroMiddle, 11, 14, 17};
  std::vector<int> keep;
  for (int k = 0; k < static_cast<int>(x.size()); ++k)
    if (std::find(unused.begin(), unused.end(), k) == unused.end()) keep.push_back(k);
  std::vector<double> xr;
  for (int k : keep) xr.push_back(x[static_cast<std::size_t>(k)]);
  const auto f = [&](const auto* xs) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(xs)>>;
    std::vector<T> full(x.size(), T(0.0));
    for (std::size_t j = 0; j < keep.size(); ++j) full[static_cast<std::size_t>(keep[j])] = xs[j];
    return f3(full.data());
  };
  expectDerivativesAgree(f, xr, 1e-7);
}

TEST(ModelDerivatives, ChainIsOrthonormalAndExactNotFirstOrder) {
  const std::vector<double> x = chainPoint();
  const ChainErrors<double> e = chainErrors(TableKind::kThreeAxis, x.data(), x.data() + 5);
  const Mat3 C = tableAttitude(TableKind::kThreeAxis, 0.0, e, 0.7, -1.1, 2.3);
  EXPECT_LT((C.transpose() * C - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  // The first-order chain differs at second order in the errors (~1e-8), so the exact one is
  // really used.
  const Mat3 C1 = chainAttitude(chainFactors(TableKind::kThreeAxis, 0.0, e, true),
                                0.7 + e.zero_outer, -1.1 + e.zero_middle, 2.3 + e.zero_inner);
  EXPECT_GT((C - C1).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(ModelDerivatives, BenchPhysicsWithLeverArm) {
  // x = chain point | gravity | Earth rate (L) | lever arm r (B).
  std::vector<double> x = chainPoint();
  x.insert(x.end(), {9.81, 0.0, 3.9e-5, 6.1e-5, 0.05, -0.03, 0.12});
  const auto f = [](const auto* p) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(p)>>;
    const TableKind kind = TableKind::kThreeAxis;
    const ChainErrors<T> e = chainErrors(kind, p, p + kTableAxesSize);
    const T* a = p + kTableAxesSize + kTableDeviceSize;
    const ChainKinematics<T> k =
        chainKinematics(chainFactors(kind, 0.0, e), JointState<T>{a[0] + e.zero_outer, a[3], a[6]},
                        JointState<T>{a[1] + e.zero_middle, a[4], a[7]},
                        JointState<T>{a[2] + e.zero_inner, a[5], a[8]});
    const T* s = a + 9;
    const Physics<T> ph = benchPhysics(k, s[0], Vec3T<T>(s[1], s[2], s[3]));
    std::vector<T> out;
    append(&out, specificForceAt(ph, Vec3T<T>(s[4], s[5], s[6])));
    append(&out, ph.w_IB_B);
    return out;
  };
  // w_ie_L.x is zero: its column is exercised only through w_IB_B, so keep it non-degenerate.
  x[static_cast<std::size_t>(20)] = 1e-6;
  expectDerivativesAgree(f, x, 1e-7);
}

}  // namespace
}  // namespace imubench::calib::model
