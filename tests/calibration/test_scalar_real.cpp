// Scalar calibration on the two public real recordings (read-only, IMUBENCH_REAL_DATA_DIR):
// the imu_tk Xsens pair (raw counts, hand-placed poses) and imucal's example Ferraris session.
// Prints the fitted coefficients and the RMS of |a| - g before/after.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>

#include "calib/scalar/scalar_calibration.h"
#include "calib/scalar/scalar_consistency.h"
#include "io/import_real.h"
#include "nav/earth.h"

namespace imubench {
namespace {

const std::string kDir = IMUBENCH_REAL_DATA_DIR;

void print(const std::string& title, const calib::ScalarCalibrationResult& r) {
  std::cout << "== " << title << "\n" << calib::describe(r);
}

// The honesty checks of the sigmas on real data (README states the numbers): both are
// computed, the halves are compared on every coefficient both can see, and the numbers are
// finite; they are reported, not bounded (real sensors drift: that is what they measure).
void checkConsistency(const calib::RawImuData& data, const calib::ScalarCalibrationResult& r,
                      const calib::ScalarCalibrationOptions& o, bool si, std::size_t min_rows) {
  const calib::ScalarConsistency c = calib::scalarConsistency(data, r, o, si);
  std::cout << calib::describe(c);
  EXPECT_GT(c.accel_dof, 0);
  EXPECT_TRUE(std::isfinite(c.accel_normalised_rms) && c.accel_normalised_rms > 0.0);
  if (min_rows == 0) {  // a half cannot be calibrated alone: refused with the reason
    EXPECT_FALSE(c.halves_ok);
    EXPECT_NE(c.halves_why.find("distinct gravity directions"), std::string::npos) << c.halves_why;
    return;
  }
  ASSERT_TRUE(c.halves_ok) << c.halves_why;
  EXPECT_GE(c.rows.size(), min_rows);
  EXPECT_TRUE(std::isfinite(c.rms_z) && c.rms_z > 0.0);
}

TEST(ScalarReal, ImuTkXsensPair) {
  const io::RealImport in =
      io::readImuTkPair(kDir + "/imutk_xsens_acc.txt", kDir + "/imutk_xsens_gyro.txt");
  ASSERT_TRUE(in.status.ok) << in.status.message;
  ASSERT_GT(in.data.size(), 50000u);
  calib::ScalarCalibrationOptions o;
  // imu_tk's own example uses g = 9.81744 m/s^2 (Padova); we use WGS-84 normal gravity at
  // Padova's latitude 45.4 deg, 12 m, which agrees to 2e-4 m/s^2.
  o.gravity_mps2 = nav::normalGravity(45.4 * kDegToRad, 12.0);
  o.min_initial_static_s = 30.0;  // imu_tk records a 50 s initial static for the gyro bias
  o.checks.accel_min = o.checks.gyro_min = 0.0;  // 16-bit unsigned raw counts
  o.checks.accel_max = o.checks.gyro_max = 65535.0;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, false);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  print("imu_tk Xsens (raw counts)", r);
  // imu_tk's recording: an initial static then ~ 35 hand-placed poses.
  EXPECT_GE(r.spans.size(), 30u);
  EXPECT_LE(r.spans.size(), 45u);
  EXPECT_LT(r.accel_rms_after, 0.05 * r.accel_rms_before);
  EXPECT_LT(r.accel_rms_after, 0.005);
  EXPECT_LT(r.gyro_rms_after, 0.2 * r.gyro_rms_before);
  EXPECT_FALSE(r.earth_rate_usable);  // MEMS: bias scatter >> Earth rate
  checkConsistency(in.data, r, o, false, 18);
}

TEST(ScalarReal, ImucalFerrarisSession) {
  const io::RealImport in = io::readImucalCsv(kDir + "/imucal_example_ferraris_session.csv");
  ASSERT_TRUE(in.status.ok) << in.status.message;
  const io::SectionListImport sl =
      io::readImucalSectionList(kDir + "/imucal_example_ferraris_session_list.json");
  ASSERT_TRUE(sl.status.ok) << sl.status.message;
  ASSERT_EQ(sl.sections.size(), 9u);
  calib::ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, true);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  print("imucal Ferraris session (m/s^2, deg/s)", r);
  // Every annotated static face must lie inside one detected span.
  for (const io::LabelledRange& s : sl.sections) {
    if (s.name.find("rot") != std::string::npos) continue;
    bool inside = false;
    for (const calib::StaticSpan& sp : r.spans)
      inside = inside || (sp.begin <= s.start + 50 && sp.end + 50 >= s.end);
    EXPECT_TRUE(inside) << s.name;
  }
  EXPECT_LT(r.accel_rms_after, 0.02 * r.accel_rms_before);
  // The gravity directions the calibrated gyros carry from pose to pose agree with the
  // measured ones to a quarter degree (the coarse start is already close at the right rate).
  EXPECT_LT(r.gyro_rms_after, 0.01);
  EXPECT_LE(r.gyro_rms_after, r.gyro_rms_before);
  // Each face is held once (13 spans on 6 faces) and the turns come last: neither half holds
  // the six faces the accelerometer needs, so the halves are not compared (and each half alone
  // is refused, not calibrated).
  checkConsistency(in.data, r, o, true, 0);
  // issue 26: six faces leave the accelerometer misalignments held at 0; what they may hold
  // (1 % each, the consider prior) leaks into the gyro misalignments, whose sigmas now carry
  // it: xy and yx (5.5 and 4.9 sigma without the consider term) are no longer claimed at 3.5
  // sigma. xz stays at 3.9 sigma: the held misalignments hardly move it, the data show it.
  for (const char* m : {"xy", "yx"}) {
    const std::string n = std::string("gyro.misalignment.") + m;
    const double z = *calib::flatValue(r.report.values, n) / *r.report.uncertainty.at(n).sigma;
    EXPECT_LT(std::abs(z), 3.5) << n;
  }
  // Independent of the annotation, the gravity-direction fit says how many readings make one
  // rad/s. Check it against imucal's protocol: each *_rot section is one full turn (imucal's
  // FerrarisCalibration expects -360 deg). Integrating the calibrated gyro over x_rot must
  // give ~360 deg about x.
  for (const io::LabelledRange& s : sl.sections) {
    if (s.name.find("rot") == std::string::npos) continue;
    Vec3 angle = Vec3::Zero();
    for (std::size_t i = s.start; i < s.end; ++i)
      angle += r.gyro().input(in.data.gyro[i]) * (in.data.t[i] - in.data.t[i - 1]);
    std::cout << s.name << ": calibrated turn " << (angle * kRadToDeg).transpose() << " deg\n";
    EXPECT_NEAR(angle.norm() * kRadToDeg, 360.0, 15.0) << s.name;
  }
  // The readings are deg/s sampled at 102.4 Hz (imucal's own example), so the fit must find
  // about 57.3 readings per rad/s: the gyro scale comes from the gravity-direction changes
  // between poses, independent of the declared unit, so this checks rate and unit together.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.gyro().scale[k], kRadToDeg, 0.03 * kRadToDeg) << k;
}

// imu_tk's own calibration of its recording: imu_tk's test program (apps/test_imu_calib.cpp at
// github.com/Kyle-ak/imu_tk 7780270, built without its Qt plots; docs/imu-tk-comparison.md says
// how) prints, with its gravity 9.81744 m/s^2, its model a = T K (r - b) per triad:
//   accel T = [1 -0.0033593 -0.00890639; 0 1 -0.0213341; 0 0 1],
//         K = diag(0.00241278, 0.00242712, 0.00241168), b = (33124.2, 33275.2, 32364.4);
//   gyro  T = [1 0.00593634 0.00111101; 0.00808812 1 -0.0535569; 0.0253067 -0.0025513 1],
//         K = diag(0.000209295, 0.000209899, 0.000209483), b = (32777.1, 32459.8, 32511.8).
// Mapped exactly onto eq. 1 (A = T K = M^-1 diag(1/scale): scale_i = (A^-1)_ii, M_ij =
// (A^-1)_ij / scale_i, bias = -b / scale), our calibration with imu_tk's gravity and its
// constant gyro bias (interpolate_gyro_bias = false) must agree within 3 of our stated sigmas
// on every coefficient both fit.
struct ImuTkTriad {
  Mat3 T, K;
  Vec3 b;
};

calib::TriadModel fromImuTk(const ImuTkTriad& t) {
  const Mat3 A_inv = (t.T * t.K).inverse();
  calib::TriadModel m;
  Mat3 M;
  for (int i = 0; i < 3; ++i) {
    m.scale[i] = A_inv(i, i);
    M.row(i) = A_inv.row(i) / m.scale[i];
  }
  // M = [1 xy -xz; -yx 1 yz; zx -zy 1] (calib/model/sensor_equation.h).
  m.mis = calib::Misalignment{M(0, 1), -M(0, 2), -M(1, 0), M(1, 2), M(2, 0), -M(2, 1)};
  m.bias = -t.b.cwiseQuotient(m.scale);
  return m;
}

double compareTriad(const calib::CoefficientReport& rep, const std::string& triad,
                    const calib::TriadModel& ours, const calib::TriadModel& ref) {
  const std::pair<std::string, std::pair<double, double>> rows[] = {
      {"scale.x", {ours.scale.x(), ref.scale.x()}},
      {"scale.y", {ours.scale.y(), ref.scale.y()}},
      {"scale.z", {ours.scale.z(), ref.scale.z()}},
      {"bias.x", {ours.bias.x(), ref.bias.x()}},
      {"bias.y", {ours.bias.y(), ref.bias.y()}},
      {"bias.z", {ours.bias.z(), ref.bias.z()}},
      {"misalignment.xy", {ours.mis.xy, ref.mis.xy}},
      {"misalignment.xz", {ours.mis.xz, ref.mis.xz}},
      {"misalignment.yx", {ours.mis.yx, ref.mis.yx}},
      {"misalignment.yz", {ours.mis.yz, ref.mis.yz}},
      {"misalignment.zx", {ours.mis.zx, ref.mis.zx}},
      {"misalignment.zy", {ours.mis.zy, ref.mis.zy}}};
  double worst = 0.0;
  for (const auto& [name, v] : rows) {
    const auto u = rep.uncertainty.find(triad + "." + name);
    if (u == rep.uncertainty.end() || !u->second.observable || !u->second.sigma) continue;
    const double z = (v.first - v.second) / *u->second.sigma;
    std::printf("  %-24s ours %14.8g  imu_tk %14.8g  sigma %10.3g  z %6.2f\n",
                (triad + "." + name).c_str(), v.first, v.second, *u->second.sigma, z);
    worst = std::max(worst, std::abs(z));
  }
  return worst;
}

TEST(ScalarReal, AgreesWithImuTksOwnCalibrationOfItsRecording) {
  const io::RealImport in =
      io::readImuTkPair(kDir + "/imutk_xsens_acc.txt", kDir + "/imutk_xsens_gyro.txt");
  ASSERT_TRUE(in.status.ok) << in.status.message;
  calib::ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81744;         // imu_tk's test program
  o.interpolate_gyro_bias = false;  // imu_tk: the initial static's bias throughout
  o.min_initial_static_s = 30.0;
  o.checks.accel_min = o.checks.gyro_min = 0.0;
  o.checks.accel_max = o.checks.gyro_max = 65535.0;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, o, false);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ImuTkTriad acc, gyr;
  acc.T << 1, -0.0033593, -0.00890639, 0, 1, -0.0213341, 0, 0, 1;
  acc.K = Vec3(0.00241278, 0.00242712, 0.00241168).asDiagonal();
  acc.b = Vec3(33124.2, 33275.2, 32364.4);
  gyr.T << 1, 0.00593634, 0.00111101, 0.00808812, 1, -0.0535569, 0.0253067, -0.0025513, 1;
  gyr.K = Vec3(0.000209295, 0.000209899, 0.000209483).asDiagonal();
  gyr.b = Vec3(32777.1, 32459.8, 32511.8);
  const double worst_acc = compareTriad(r.report, "accel", r.accel(), fromImuTk(acc));
  const double worst_gyr = compareTriad(r.report, "gyro", r.gyro(), fromImuTk(gyr));
  EXPECT_LT(worst_acc, 3.0);
  EXPECT_LT(worst_gyr, 3.0);
}

}  // namespace
}  // namespace imubench
