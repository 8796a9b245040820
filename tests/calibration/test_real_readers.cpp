// Third-party readers name bad input at file:line: NaN and infinities, truncated rows, time
// that does not increase; imu_tk-layout files with signed readings are not unsigned counts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "io/import_real.h"

namespace imubench {
namespace {

class RealReaders : public ::testing::Test {
 protected:
  std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("imubench_readers_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
       "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  void SetUp() override { std::filesystem::create_directories(dir_); }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = (dir_ / name).string();
    std::ofstream(p) << text;
    return p;
  }
};

const char* kImucalHeader = "n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z\n";

TEST_F(RealReaders, ImucalNanNamedAtFileLine) {
  const std::string p =
      write("s.csv", std::string(kImucalHeader) + "0,0,0,0,0,0,9.8\n1,0,nan,0,0,0,9.8\n");
  const io::RealImport r = io::readImucalCsv(p);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(p + ":3: column gyr_y is NaN", 0), 0u) << r.status.message;
}

TEST_F(RealReaders, ImucalTruncatedRowNamedAtFileLine) {
  const std::string p = write("s.csv", std::string(kImucalHeader) + "0,0,0,0,0,0,9.8\n1,0,0,0,0");
  const io::RealImport r = io::readImucalCsv(p);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(p + ":3: expected 7 columns", 0), 0u) << r.status.message;
}

TEST_F(RealReaders, ImuTkInfinityAndTimeNamedAtFileLine) {
  const std::string g = write("g.txt", "0.01 1 2 3\n0.02 1 2 3\n");
  const std::string a1 = write("a1.txt", "0.01 1 2 3\n0.02 1 inf 3\n");
  io::RealImport r = io::readImuTkPair(a1, g);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(a1 + ":2: column 3 is NaN or infinite", 0), 0u)
      << r.status.message;
  const std::string a2 = write("a2.txt", "0.02 1 2 3\n0.01 1 2 3\n");
  r = io::readImuTkPair(a2, g);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message, a2 + ":2: time does not increase");
}

TEST_F(RealReaders, ImuTkSignedReadingsAreNotUnsignedCounts) {
  const std::string a = write("a.txt", "0.01 -120 2 16000\n0.02 -118 3 16001\n");
  const std::string g = write("g.txt", "0.01 -4 2 3\n0.02 -5 2 3\n");
  io::RealImport r = io::readImuTkPair(a, g);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_FALSE(r.unsigned_counts);
  const std::string a2 = write("a2.txt", "0.01 33108 33329 36429\n0.02 33096 33336 36437\n");
  const std::string g2 = write("g2.txt", "0.01 32786 32429 32499\n0.02 32797 32410 32531\n");
  r = io::readImuTkPair(a2, g2);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(r.unsigned_counts);
  EXPECT_EQ(r.accel_unit, "count");
}

TEST_F(RealReaders, SixColumnLogErrorsAtFileLine) {
  const std::string p = write("imu0.log", "-8.4 0.06 5.2 0.03 0.002 0.04\n-8.4 0.06 5.2 NaN 0 0\n");
  io::RealImport r = io::readSixColumnLog(p);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(p + ":2: column wx is NaN", 0), 0u) << r.status.message;
  const std::string q = write("imu1.log", "-8.4 0.06 5.2 0.03 0.002 0.04\n-8.4 0.06 5.2 0.03\n");
  r = io::readSixColumnLog(q);
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message.rfind(q + ":2: expected 6 columns", 0), 0u) << r.status.message;
  const std::string ok = write("imu2.log", "-8.4 0.06 5.2 0.03 0.002 0.04\n-8.4 0.06 5.2 0 0 0\n");
  r = io::readSixColumnLog(ok, 100.0);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(r.data.size(), 2u);
  EXPECT_DOUBLE_EQ(r.data.t[1], 0.01);
  EXPECT_EQ(r.gyro_unit, "rad/s");
}

}  // namespace
}  // namespace imubench
