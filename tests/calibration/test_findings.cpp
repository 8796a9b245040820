// The seed paper's analytic findings on direct calibration, checked numerically on simulated
// bundled plans with noise off (so the checks are sharp):
//  1. scale factors and biases of both triads do not change when table errors are added;
//  2. gyro misalignments move only with the mounting angles (beta', gamma'), not with the base
//     tilt (beta_oc, gamma_oc);
//  3. accelerometer misalignments move with the mounting AND the base tilt.
// First-order prediction for mounting mu = (mx, my, 0): the table reports C_LB_nom while the
// body sits at C_LB_nom (I + [mu x]), so both triads fit M' = M (I - [mu x]) ~ M - [mu x]:
//   d m_xz = +my, d m_yz = +mx, d m_zx = +my, d m_zy = +mx, d m_xy = d m_yx = 0.
#include <gtest/gtest.h>

#include "calib/direct_calibration.h"
#include "test_direct_sim.h"

namespace imubench::calib {
namespace {

using testing::exampleSensors;
using testing::libraryMotion;
using testing::simulateDirect;

constexpr double kAs = kArcsecToRad;

struct Delta {
  Vec3 accel_scale, accel_bias, gyro_scale, gyro_bias;
  Misalignment accel_mis, gyro_mis;
};

Misalignment diff(const Misalignment& a, const Misalignment& b) {
  return {a.xy - b.xy, a.xz - b.xz, a.yx - b.yx, a.yz - b.yz, a.zx - b.zx, a.zy - b.zy};
}
double maxAbs(const Misalignment& m) {
  return std::max({std::abs(m.xy), std::abs(m.xz), std::abs(m.yx), std::abs(m.yz), std::abs(m.zx),
                   std::abs(m.zy)});
}

class Findings : public ::testing::TestWithParam<std::string> {
 protected:
  static SensorModel calibrate(const Motion& motion, const TableErrors& e) {
    const DirectCalibrationResult r = calibrateDirect(simulateDirect(motion, exampleSensors(), e));
    EXPECT_TRUE(r.status.HasResult()) << r.status.message;
    return r.report.values.sensors;
  }
  // Coefficient changes caused by the table errors e, against a perfect table.
  Delta delta(const TableErrors& e) {
    if (motion_.axes.empty()) {
      motion_ = libraryMotion(GetParam());
      base_ = calibrate(motion_, {});
    }
    const SensorModel s = calibrate(motion_, e);
    return {s.accel.scale - base_.accel.scale,  s.accel.bias - base_.accel.bias,
            s.gyro.scale - base_.gyro.scale,    s.gyro.bias - base_.gyro.bias,
            diff(s.accel.mis, base_.accel.mis), diff(s.gyro.mis, base_.gyro.mis)};
  }
  Motion motion_;
  SensorModel base_;
};

TableErrors mounting() {
  TableErrors e;
  e.mounting = Vec2(60.0 * kAs, -45.0 * kAs);
  return e;
}
TableErrors baseTilt() {
  TableErrors e;
  e.base_tilt = Vec2(40.0 * kAs, 50.0 * kAs);
  return e;
}

// A first-order leak of a ~50" error would be ~2.5e-4 (relative, rad) or g * 2.5e-4 =
// 2.4e-3 m/s^2; the tolerances are 100x below that.
void expectScalesAndBiasesUnchanged(const Delta& d) {
  EXPECT_LT(d.accel_scale.cwiseAbs().maxCoeff(), 2e-6) << d.accel_scale.transpose();
  EXPECT_LT(d.accel_bias.cwiseAbs().maxCoeff(), 2e-5) << d.accel_bias.transpose();
  EXPECT_LT(d.gyro_scale.cwiseAbs().maxCoeff(), 2e-6) << d.gyro_scale.transpose();
  EXPECT_LT(d.gyro_bias.cwiseAbs().maxCoeff(), 1e-9) << d.gyro_bias.transpose();
}

void expectMountingPrediction(const Misalignment& m, const Vec2& mu, const char* triad) {
  const double tol = 2e-6;  // second-order terms: |mu| * |misalignment| ~ 3e-7
  EXPECT_NEAR(m.xy, 0.0, tol) << triad;
  EXPECT_NEAR(m.yx, 0.0, tol) << triad;
  EXPECT_NEAR(m.xz, mu.y(), tol) << triad;
  EXPECT_NEAR(m.yz, mu.x(), tol) << triad;
  EXPECT_NEAR(m.zx, mu.y(), tol) << triad;
  EXPECT_NEAR(m.zy, mu.x(), tol) << triad;
}

TEST_P(Findings, ScalesAndBiasesIgnoreMounting) {
  expectScalesAndBiasesUnchanged(delta(mounting()));
}

TEST_P(Findings, ScalesAndBiasesIgnoreBaseTilt) {
  expectScalesAndBiasesUnchanged(delta(baseTilt()));
}

TEST_P(Findings, ScalesAndBiasesIgnoreBothTogether) {
  TableErrors e = mounting();
  e.base_tilt = baseTilt().base_tilt;
  expectScalesAndBiasesUnchanged(delta(e));
}

TEST_P(Findings, GyroMisalignmentsMoveWithMountingAsPredicted) {
  expectMountingPrediction(delta(mounting()).gyro_mis, mounting().mounting, "gyro");
}

TEST_P(Findings, GyroMisalignmentsIgnoreBaseTilt) {
  const Delta d = delta(baseTilt());
  EXPECT_LT(maxAbs(d.gyro_mis), 1e-6);
}

TEST_P(Findings, AccelMisalignmentsMoveWithMountingAsPredicted) {
  expectMountingPrediction(delta(mounting()).accel_mis, mounting().mounting, "accel");
}

TEST_P(Findings, AccelMisalignmentsMoveWithBaseTilt) {
  const Delta d = delta(baseTilt());
  // The leak is of the order of the tilt itself (not a second-order effect).
  EXPECT_GT(maxAbs(d.accel_mis), 0.3 * baseTilt().base_tilt.norm());
  EXPECT_LT(maxAbs(d.accel_mis), 3.0 * baseTilt().base_tilt.norm());
}

TEST_P(Findings, TriadsEndUpMutuallyMisalignedByTheBaseTilt) {
  // Mounting moves both triads alike (their mutual misalignment stays); base tilt moves only
  // the accelerometers: the gyro triad is tied to the table axes, the accelerometer triad to
  // gravity.
  TableErrors e = mounting();
  const Delta dm = delta(e);
  EXPECT_LT(maxAbs(diff(dm.accel_mis, dm.gyro_mis)), 2e-6);
  e.base_tilt = baseTilt().base_tilt;
  const Delta dmt = delta(e);
  EXPECT_GT(maxAbs(diff(dmt.accel_mis, dmt.gyro_mis)), 0.3 * baseTilt().base_tilt.norm());
}

INSTANTIATE_TEST_SUITE_P(Bundled, Findings,
                         ::testing::Values("direct_two_axis", "direct_three_axis"));

}  // namespace
}  // namespace imubench::calib
