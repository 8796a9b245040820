// io/logger_csv.h units and refusals, io/format_hint.h, and a recording without table angles
// (table.csv with its header alone) written and read back.
#include "io/logger_csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "io/coeff_export.h"
#include "io/format_hint.h"
#include "io/recording.h"

namespace imubench {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() /
                     ("imubench-io-" + name + "-" +
                      std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

void writeText(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

TEST(ColumnUnit, PhysicalCountsAndLsb) {
  io::ColumnUnit u;
  std::string why;
  ASSERT_TRUE(io::parseColumnUnit('w', "deg/s", &u, &why)) << why;
  EXPECT_DOUBLE_EQ(u.factor, M_PI / 180.0);
  EXPECT_FALSE(u.increment);
  ASSERT_TRUE(io::parseColumnUnit('a', "g", &u, &why));
  EXPECT_DOUBLE_EQ(u.factor, 9.80665);
  ASSERT_TRUE(io::parseColumnUnit('a', "m/s", &u, &why));
  EXPECT_TRUE(u.increment);
  ASSERT_TRUE(io::parseColumnUnit('w', "lsb:131:deg/s", &u, &why)) << why;
  EXPECT_DOUBLE_EQ(u.factor, M_PI / 180.0 / 131.0);
  ASSERT_TRUE(io::parseColumnUnit('a', "count:0.5:g", &u, &why)) << why;
  EXPECT_DOUBLE_EQ(u.factor, 0.5 * 9.80665);
  ASSERT_TRUE(io::parseColumnUnit('t', "us", &u, &why));
  EXPECT_DOUBLE_EQ(u.factor, 1e-6);
  EXPECT_FALSE(io::parseColumnUnit('w', "deg/h", &u, &why));
  EXPECT_NE(why.find("deg/s"), std::string::npos) << why;
  EXPECT_FALSE(io::parseColumnUnit('a', "lsb:-3:g", &u, &why));
  EXPECT_FALSE(io::parseColumnUnit('t', "count:1:s", &u, &why));
}

io::LoggerImportOptions sixColumns(const fs::path& file) {
  io::LoggerImportOptions o;
  o.path = file.string();
  o.columns = {{"t", {"1"}},  {"ax", {"2"}}, {"ay", {"3"}}, {"az", {"4"}},
               {"wx", {"5"}}, {"wy", {"6"}}, {"wz", {"7"}}};
  o.gravity_mps2 = 9.81;
  return o;
}

TEST(LoggerImport, EveryBadRowNamedAndNothingKept) {
  const fs::path d = scratch("bad");
  writeText(d / "log.csv",
            "0.01,0,0,9.81,0,0,0\n0.02,0,0,9.81,0,0,0\n0.02,0,0,9.81,0,0,0\n0.04,0,0,nan,0,0,0\n"
            "0.05,0,0,9.81,0,0\n0.06,0,0,9.81,0,0,0\n");
  const io::LoggerImport r = io::importLogger(sixColumns(d / "log.csv"));
  ASSERT_FALSE(r.status.ok);
  ASSERT_EQ(r.bad_rows.size(), 3u);
  EXPECT_EQ(r.bad_rows[0].line, 3);  // time not increasing
  EXPECT_EQ(r.bad_rows[1].line, 4);  // NaN
  EXPECT_EQ(r.bad_rows[2].line, 5);  // 6 columns
  EXPECT_NE(r.status.message.find(":3: time"), std::string::npos) << r.status.message;
  EXPECT_TRUE(r.recording.imu.empty());
}

TEST(LoggerImport, SkipBadRowsKeepsTheRestAndMeasuresTiming) {
  const fs::path d = scratch("skip");
  std::string text;
  for (int k = 1; k <= 50; ++k)
    text += std::to_string(0.01 * k) + (k == 20 ? ",x" : ",0") + ",0,9.81,0.01,0,0\n";
  writeText(d / "log.csv", text);
  io::LoggerImportOptions o = sixColumns(d / "log.csv");
  o.skip_bad_rows = true;
  const io::LoggerImport r = io::importLogger(o);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.recording.imu.size(), 49u);
  ASSERT_EQ(r.bad_rows.size(), 1u);
  EXPECT_EQ(r.bad_rows[0].line, 20);
  EXPECT_NEAR(r.timing.median_dt_s, 0.01, 1e-12);
  ASSERT_EQ(r.timing.gaps.size(), 1u);  // the row left out leaves a 0.02 s interval
  EXPECT_EQ(r.timing.gaps[0].line, 21);
  EXPECT_NEAR(r.recording.imu[19].dtheta.x(), 0.01 * 0.02, 1e-12);  // held over the gap
}

TEST(RecordingWithoutTable, HeaderOnlyTableReadsBackEmpty) {
  const fs::path d = scratch("notable");
  io::Recording rec;
  rec.imu_serial = "S";
  rec.imu_rate_hz = 100.0;
  rec.latitude_deg = 10.0;
  for (int k = 1; k <= 10; ++k) {
    nav::ImuSample s;
    s.t = 0.01 * k;
    s.dvel = Vec3(0.0, 0.0, 0.0981);
    rec.imu.push_back(s);
  }
  ASSERT_TRUE(io::writeRecording(d.string(), rec).ok);
  std::ifstream t(d / "table.csv");
  std::string first, rest;
  std::getline(t, first);
  EXPECT_EQ(first, "t,outer,inner");
  EXPECT_FALSE(std::getline(t, rest)) << "table.csv has rows: " << rest;
  const io::RecordingReadResult r = io::readRecording(d.string());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(r.value.table.empty());
  EXPECT_TRUE(r.value.segments.empty());
  EXPECT_EQ(r.value.imu.size(), 10u);
}

TEST(FormatHint, NamesTheMatchingFormatOrImportCsv) {
  const fs::path d = scratch("hint");
  writeText(d / "a.txt", "0.01 1 2 3\n");
  writeText(d / "b.log", "1 2 3 4 5 6\n");
  writeText(d / "c.csv", "n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z\n0,1,2,3,4,5,6\n");
  writeText(d / "d.csv", "time_ms;gx;gy;gz;ax;ay;az\n");
  EXPECT_NE(io::recordingFileHint((d / "a.txt").string()).find("--format imutk"),
            std::string::npos);
  EXPECT_NE(io::recordingFileHint((d / "b.log").string()).find("--format imu-calib"),
            std::string::npos);
  EXPECT_NE(io::recordingFileHint((d / "c.csv").string()).find("--format imucal"),
            std::string::npos);
  const std::string h = io::recordingFileHint((d / "d.csv").string());
  EXPECT_NE(h.find("import-csv"), std::string::npos) << h;
  EXPECT_NE(h.find("time_ms"), std::string::npos) << h;
  EXPECT_EQ(io::recordingFileHint((d / "missing").string()), "");
}

TEST(CoefficientExport, ChainFileRefusedWithoutNoise) {
  io::ExportInput in;
  in.source = "c.json";
  const io::ExportResult r = io::exportCoefficients(io::ExportTarget::kOpenVins, in);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("--recording"), std::string::npos) << r.status.message;
}

}  // namespace
}  // namespace imubench
