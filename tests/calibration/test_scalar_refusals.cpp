// Scalar calibration refuses data that cannot determine its coefficients instead of returning
// numbers: each case is a real recording (imucal's Ferraris session, read-only) altered the way
// other loggers' files go wrong — columns swapped under a correct header, two accelerometer
// axes exchanged (a mirrored triad), one orientation held throughout. The unaltered session
// and the MPU-9150 log from imu-calib calibrate (checked in test_scalar_real.cpp and here).
#include <gtest/gtest.h>

#include <utility>

#include "calib/scalar/scalar_calibration.h"
#include "io/import_real.h"

namespace imubench {
namespace {

const std::string kDir = IMUBENCH_REAL_DATA_DIR;

calib::RawImuData ferraris() {
  const io::RealImport in = io::readImucalCsv(kDir + "/imucal_example_ferraris_session.csv");
  EXPECT_TRUE(in.status.ok) << in.status.message;
  return in.data;
}

calib::ScalarCalibrationResult calibrate(const calib::RawImuData& d) {
  calib::ScalarCalibrationOptions o;
  o.gravity_mps2 = 9.81;
  return calib::scalarCalibrate(d, o, true);
}

TEST(ScalarRefusals, UnalteredSessionCalibrates) {
  const calib::ScalarCalibrationResult r = calibrate(ferraris());
  EXPECT_TRUE(r.status.ok) << r.status.message;
}

TEST(ScalarRefusals, AccelAndGyroColumnSwappedIsRefused) {
  calib::RawImuData d = ferraris();
  for (std::size_t i = 0; i < d.size(); ++i) std::swap(d.accel[i].x(), d.gyro[i].x());
  const calib::ScalarCalibrationResult r = calibrate(d);
  ASSERT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("far from g"), std::string::npos) << r.status.message;
}

TEST(ScalarRefusals, MirroredAccelerometerIsRefused) {
  calib::RawImuData d = ferraris();
  for (std::size_t i = 0; i < d.size(); ++i) std::swap(d.accel[i].x(), d.accel[i].y());
  const calib::ScalarCalibrationResult r = calibrate(d);
  ASSERT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("gyro"), std::string::npos) << r.status.message;
}

TEST(ScalarRefusals, OneOrientationIsRefused) {
  const calib::RawImuData full = ferraris();
  // The first face's samples repeated for the length of the session (quiet, one direction).
  calib::RawImuData d;
  const std::size_t face = 200;
  for (std::size_t i = 0; i < 40 * face; ++i) {
    d.t.push_back(static_cast<double>(i) / io::kImucalExampleRateHz);
    d.accel.push_back(full.accel[i % face]);
    d.gyro.push_back(full.gyro[i % face]);
  }
  const calib::ScalarCalibrationResult r = calibrate(d);
  ASSERT_FALSE(r.status.ok) << "coefficients from one orientation";
  // Refused for the geometry: the spliced repeats are one quiet span, one pose where the
  // accelerometer's 3 scales and 3 biases need six (not a gap, a bad option or a solver failure).
  EXPECT_EQ(r.status.code, calib::RecordingStatusCode::kTooFewStatics) << r.status.message;
  EXPECT_NE(r.status.message.find("found 1 static poses, need >= 6"), std::string::npos)
      << r.status.message;
}

TEST(ScalarRefusals, FewTiltsDoNotDetermineAnAxis) {
  // Only the poses whose z axis points up or down: x and y never see gravity's full range.
  const calib::RawImuData full = ferraris();
  calib::RawImuData d;
  for (std::size_t i = 0; i < full.size(); ++i) {
    const double tilt = full.accel[i].z() / full.accel[i].norm();
    if (std::abs(tilt) < 0.9) continue;
    d.t.push_back(static_cast<double>(d.t.size()) / io::kImucalExampleRateHz);
    d.accel.push_back(full.accel[i]);
    d.gyro.push_back(full.gyro[i]);
  }
  const calib::ScalarCalibrationResult r = calibrate(d);
  ASSERT_FALSE(r.status.ok) << "coefficients from two faces";
  // Refused for the poses: the samples kept (z up or down) hold four static poses, fewer
  // than the six the accelerometer's scales and biases need (not a gap or a solver failure).
  EXPECT_EQ(r.status.code, calib::RecordingStatusCode::kTooFewStatics) << r.status.message;
  EXPECT_NE(r.status.message.find("found 4 static poses, need >= 6"), std::string::npos)
      << r.status.message;
}

TEST(ScalarRefusals, SixColumnMpuLogCalibrates) {
  const io::RealImport in = io::readSixColumnLog(kDir + "/mikoff_mpu9150_imu0.log");
  ASSERT_TRUE(in.status.ok) << in.status.message;
  const calib::ScalarCalibrationResult r = calibrate(in.data);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.accel_rms_after, 0.01);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.accel().scale[k], 1.0, 0.02);
  EXPECT_GE(r.rotations_used, 6);
}

}  // namespace
}  // namespace imubench
