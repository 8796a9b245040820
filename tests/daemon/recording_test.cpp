// imubench-csv/1 recordings: bit-exact round trip, strict refusal of malformed files with
// file:line and the reason, and segment derivation from table motion.
#include "io/recording.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "tests/daemon/recording_fixtures.h"

namespace imubench::daemon {
namespace {

using testing::AwkwardDoubles;
using testing::expectSameRecording;
using testing::ScratchDir;

namespace fs = std::filesystem;

// Awkward doubles on purpose: random mantissas over many exponents, negative zero, subnormal,
// extremes.
io::Recording makeRecording(unsigned seed, calib::TableKind kind, size_t n_imu) {
  AwkwardDoubles d(seed);
  const double height_m = 156.0 + d.odd();
  io::Recording rec = testing::awkwardRecording(d, kind, n_imu, height_m, "SN-0042 \"test\"");
  for (int i = 0; i < 50; ++i) {
    io::TableSample s;
    s.t = 0.01 * i + d.odd() * 1e-6;
    for (int a = 0; a < calib::axisCount(kind); ++a)
      s.angles_deg[static_cast<size_t>(a)] = 180.0 * d.unit();
    rec.table.push_back(s);
  }
  rec.chamber = {{0.0, 25.0, 24.9 + d.odd()}, {10.0 / 3.0, 25.0, 25.0 + d.odd()}};
  calib::Segment a;
  a.t0 = 0.0;
  a.t1 = 0.2;
  a.kind = calib::SegmentKind::kStatic;
  a.label = "pos 1, \"up\"";
  calib::Segment b;
  b.t0 = 0.2;
  b.t1 = 0.4;
  b.kind = calib::SegmentKind::kRotate;
  b.label = "run-1";
  rec.segments = {a, b};
  return rec;
}

TEST(RecordingRoundTrip, TwoAxisIsBitExact) {
  ScratchDir dir("rec-rt2");
  const io::Recording rec = makeRecording(7, calib::TableKind::kTwoAxis, 20000);
  const auto st = io::writeRecording(dir.str(), rec);
  ASSERT_TRUE(st.ok) << st.message;
  const auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(r.value.segments_from_file);
  expectSameRecording(rec, r.value);
}

TEST(RecordingRoundTrip, ThreeAxisWithoutOptionalFilesIsBitExact) {
  ScratchDir dir("rec-rt3");
  io::Recording rec = makeRecording(11, calib::TableKind::kThreeAxis, 500);
  rec.chamber.clear();
  rec.segments.clear();
  rec.gravity_mps2.reset();
  ASSERT_TRUE(io::writeRecording(dir.str(), rec).ok);
  EXPECT_FALSE(fs::exists(dir.file("chamber.csv")));
  EXPECT_FALSE(fs::exists(dir.file("segments.csv")));
  auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_FALSE(r.value.segments_from_file);
  EXPECT_FALSE(r.value.segments.empty());  // derived from the table motion
  r.value.segments.clear();
  expectSameRecording(rec, r.value);
}

TEST(RecordingRoundTrip, WriteRefusesNonFinite) {
  ScratchDir dir("rec-nf");
  io::Recording rec = makeRecording(3, calib::TableKind::kTwoAxis, 10);
  rec.imu[5].dvel.x() = std::numeric_limits<double>::infinity();
  const auto st = io::writeRecording(dir.str(), rec);
  EXPECT_FALSE(st.ok);
  EXPECT_NE(st.message.find("IMU sample 5"), std::string::npos) << st.message;
}

// ---- Malformed recordings ----

void writeText(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
}

const char* kGoodMeta = R"({"format": "imubench-csv/1",
 "site": {"latitude_deg": 55.0, "height_m": 150.0},
 "imu": {"serial": "A1", "rate_hz": 100},
 "table": {"kind": "two-axis"}})";
const char* kGoodImu =
    "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n"
    "0.01,0,0,0,0,0,0.098,25\n"
    "0.02,0,0,0,0,0,0.098,\n"
    "0.03,0,0,0,0,0,0.098,25\n";
const char* kGoodTable = "t,outer,inner\n0,0,0\n1,0,0\n2,0,0\n";

struct BadCase {
  const char* name;
  const char* file;      // which file to replace
  const char* contents;  // nullptr: delete the file
  const char* expect_where;
  const char* expect_reason;
};

class MalformedRecording : public ::testing::TestWithParam<BadCase> {};

TEST_P(MalformedRecording, IsRefusedWithFileLineAndReason) {
  const BadCase& c = GetParam();
  ScratchDir dir(std::string("rec-") + c.name);
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("imu.csv"), kGoodImu);
  writeText(dir.file("table.csv"), kGoodTable);
  {
    // Sanity: the good recording reads.
    const auto good = io::readRecording(dir.str());
    ASSERT_TRUE(good.status.ok) << good.status.message;
  }
  if (c.contents) {
    writeText(dir.file(c.file), c.contents);
  } else {
    fs::remove(dir.file(c.file));
  }
  const auto r = io::readRecording(dir.str());
  ASSERT_FALSE(r.status.ok);
  const std::string where = dir.file(c.file) + c.expect_where;
  EXPECT_EQ(r.status.message.rfind(where, 0), 0u)
      << "message: " << r.status.message << "\nexpected prefix: " << where;
  EXPECT_NE(r.status.message.find(c.expect_reason), std::string::npos)
      << "message: " << r.status.message << "\nexpected reason: " << c.expect_reason;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, MalformedRecording,
    ::testing::Values(
        BadCase{"missing_imu", "imu.csv", nullptr, ": ", "missing file"},
        BadCase{"missing_meta", "meta.json", nullptr, ": ", "missing file"},
        BadCase{"imu_wrong_header", "imu.csv", "t,gx,gy,gz,ax,ay,az,temp\n0.01,0,0,0,0,0,0,\n",
                ":1: ", "wrong header"},
        BadCase{"imu_wrong_unit_header", "imu.csv", "t_ms,dthx,dthy,dthz,dvx,dvy,dvz,temp\n",
                ":1: ", "wrong header"},
        BadCase{"imu_short_row", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,25\n0.02,0,0,0,0,0,25\n",
                ":3: ", "expected 8 fields, got 7"},
        BadCase{"imu_long_row", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,25,1\n",
                ":2: ", "expected 8 fields, got 9"},
        BadCase{"imu_not_number", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,25\n0.02,0,abc,0,0,0,0,25\n",
                ":3: ", "column 'dthy': not a number 'abc'"},
        BadCase{"imu_trailing_garbage", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0.5x,0,25\n",
                ":2: ", "column 'dvy': not a number"},
        BadCase{"imu_space", "imu.csv", "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0, 1,0,0,0,0,25\n",
                ":2: ", "column 'dthy': not a number"},
        BadCase{"imu_nan", "imu.csv", "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,nan,0,0,0,25\n",
                ":2: ", "column 'dthz': non-finite"},
        BadCase{"imu_inf", "imu.csv", "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,inf,0,0,25\n",
                ":2: ", "column 'dvx': non-finite"},
        BadCase{"imu_overflow", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,1e999,25\n",
                ":2: ", "out of range"},
        BadCase{"imu_empty_time", "imu.csv", "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n,0,0,0,0,0,0,25\n",
                ":2: ", "column 't' is empty"},
        BadCase{"imu_time_back", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,\n0.03,0,0,0,0,0,0,\n0.02,0,0,"
                "0,0,0,0,\n",
                ":4: ", "times must strictly increase"},
        BadCase{"imu_time_repeat", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,\n0.01,0,0,0,0,0,0,\n",
                ":3: ", "not after"},
        BadCase{"imu_empty_line", "imu.csv",
                "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0,\n\n0.02,0,0,0,0,0,0,\n",
                ":3: ", "empty line"},
        BadCase{"imu_no_rows", "imu.csv", "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n",
                ":2: ", "no samples"},
        BadCase{"imu_empty_file", "imu.csv", "", ":1: ", "empty file"},
        BadCase{"table_three_axis_header", "table.csv", "t,outer,middle,inner\n0,0,0,0\n",
                ":1: ", "meta.json says two-axis"},
        BadCase{"table_bad_angle", "table.csv", "t,outer,inner\n0,0,0\n1,0,1.2.3\n",
                ":3: ", "column 'inner': not a number '1.2.3'"},
        BadCase{"chamber_bad_header", "chamber.csv", "t,setpoint\n0,25\n", ":1: ", "wrong header"},
        BadCase{"chamber_bad_row", "chamber.csv", "t,setpoint,temp\n0,25,24\n5,25\n",
                ":3: ", "expected 3 fields, got 2"},
        BadCase{"segments_unknown_kind", "segments.csv",
                "t0,t1,kind,label\n0,1,static,a\n1,2,spin,b\n",
                ":3: ", "unknown segment kind 'spin'"},
        BadCase{"segments_reversed", "segments.csv", "t0,t1,kind,label\n2,1,static,a\n",
                ":2: ", "is not after t0"},
        BadCase{"segments_overlap", "segments.csv",
                "t0,t1,kind,label\n0,2,static,a\n1,3,rotate,b\n", ":3: ", "overlap"},
        BadCase{"segments_few_fields", "segments.csv", "t0,t1,kind,label\n0,2,static\n",
                ":2: ", "expected 4 fields"},
        BadCase{"segments_unquoted_comma", "segments.csv", "t0,t1,kind,label\n0,2,static,a,b\n",
                ":2: ", "not quoted"},
        BadCase{
            "meta_wrong_format", "meta.json",
            R"({"format": "imubench-csv/2", "site": {"latitude_deg": 55, "height_m": 0}, "imu": {"serial": "A", "rate_hz": 100}, "table": {"kind": "two-axis"}})",
            ": ", "unsupported format"},
        BadCase{"meta_syntax", "meta.json", "{\"format\": \"imubench-csv/1\",\n \"site\": {,\n}",
                ":2: ", "JSON syntax error"},
        BadCase{
            "meta_missing_rate", "meta.json",
            R"({"format": "imubench-csv/1", "site": {"latitude_deg": 55, "height_m": 0}, "imu": {"serial": "A"}, "table": {"kind": "two-axis"}})",
            ": ", "missing 'imu.rate_hz'"},
        BadCase{
            "meta_string_latitude", "meta.json",
            R"({"format": "imubench-csv/1", "site": {"latitude_deg": "55 deg", "height_m": 0}, "imu": {"serial": "A", "rate_hz": 100}, "table": {"kind": "two-axis"}})",
            ": ", "'site.latitude_deg' must be a number"},
        BadCase{
            "meta_bad_kind", "meta.json",
            R"({"format": "imubench-csv/1", "site": {"latitude_deg": 55, "height_m": 0}, "imu": {"serial": "A", "rate_hz": 100}, "table": {"kind": "gimbal"}})",
            ": ", "unknown 'table.kind'"}),
    [](const ::testing::TestParamInfo<BadCase>& p) { return std::string(p.param.name); });

TEST(Recording, CrLfLineEndingsAreAccepted) {
  ScratchDir dir("rec-crlf");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("imu.csv"),
            "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\r\n0.01,0,0,0,0,0,0.098,25\r\n");
  writeText(dir.file("table.csv"), "t,outer,inner\r\n0,0,0\r\n1,0,0");  // no final newline
  const auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.value.imu.size(), 1u);
  EXPECT_EQ(r.value.table.size(), 2u);
  EXPECT_DOUBLE_EQ(r.value.imu[0].dvel.z(), 0.098);
}

// The reader's fast path (fast_float) calls an underflow 0; the strict parse refuses it as out
// of range, like an overflow, and a plain zero still reads.
TEST(Recording, UnderflowIsOutOfRangeAndZeroReads) {
  ScratchDir dir("rec-underflow");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("table.csv"), kGoodTable);
  writeText(dir.file("imu.csv"),
            "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,-0,0e3,0,0,0.098,25\n"
            "0.02,0,0,1e-400,0,0,0.098,25\n");
  const auto r = io::readRecording(dir.str());
  ASSERT_FALSE(r.status.ok);
  EXPECT_EQ(r.status.message,
            dir.file("imu.csv") + ":3: column 'dthz': number out of range '1e-400'");
  writeText(dir.file("imu.csv"), "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,-0,0e3,0,0,0.098,25\n");
  const auto ok = io::readRecording(dir.str());
  ASSERT_TRUE(ok.status.ok) << ok.status.message;
  EXPECT_TRUE(std::signbit(ok.value.imu[0].dtheta.y()));
}

TEST(Recording, NotADirectory) {
  const auto r = io::readRecording("/nonexistent/imubench/recording");
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("not a directory"), std::string::npos);
}

// ---- Segment derivation ----

// Table history of a two-axis plan: hold 5 s, rotate the inner axis +180 deg at 10 deg/s
// (wrapping the encoder through 180 -> -180), hold 5 s, move both axes, hold 5 s.
std::vector<io::TableSample> syntheticTable() {
  std::vector<io::TableSample> t;
  const double dt = 0.01;
  auto push = [&](double time, double outer, double inner) {
    io::TableSample s;
    s.t = time;
    s.angles_deg = {outer, inner, 0.0};
    t.push_back(s);
  };
  auto wrap = [](double a) { return std::remainder(a, 360.0); };
  double time = 0.0;
  for (int i = 0; i < 500; ++i, time += dt) push(time, 0.0, 90.0);  // static 0..5
  for (int i = 0; i < 1800; ++i, time += dt)
    push(time, 0.0, wrap(90.0 + 10.0 * i * dt));                           // rotate 5..23
  for (int i = 0; i < 500; ++i, time += dt) push(time, 0.0, wrap(270.0));  // static 23..28
  for (int i = 0; i < 300; ++i, time += dt)
    push(time, 5.0 * i * dt, wrap(270.0 - 5.0 * i * dt));                    // move
  for (int i = 0; i <= 500; ++i, time += dt) push(time, 15.0, wrap(255.0));  // static
  return t;
}

TEST(DeriveSegments, StaticRotateStaticMoveStatic) {
  const auto table = syntheticTable();
  const auto segs = io::deriveSegments(calib::TableKind::kTwoAxis, table);
  ASSERT_EQ(segs.size(), 5u);
  EXPECT_EQ(segs[0].kind, calib::SegmentKind::kStatic);
  EXPECT_EQ(segs[1].kind, calib::SegmentKind::kRotate);
  EXPECT_EQ(segs[2].kind, calib::SegmentKind::kStatic);
  EXPECT_EQ(segs[3].kind, calib::SegmentKind::kMove);
  EXPECT_EQ(segs[4].kind, calib::SegmentKind::kStatic);
  EXPECT_EQ(segs[1].axis, 1);
  EXPECT_NEAR(segs[1].angle, kPi, 1e-9);  // +180 deg across the encoder wrap
  EXPECT_NEAR(segs[1].t0, 5.0, 0.011);
  EXPECT_NEAR(segs[1].t1, 23.0, 0.011);
  EXPECT_EQ(segs[1].label, "rotate-1");
  EXPECT_EQ(segs[3].label, "move-1");
  for (size_t i = 1; i < segs.size(); ++i) EXPECT_DOUBLE_EQ(segs[i].t0, segs[i - 1].t1);
}

TEST(DeriveSegments, ShortPauseStaysInsideTheMotion) {
  auto table = syntheticTable();
  // Freeze the inner axis for 0.3 s in the middle of the rotation.
  for (auto& s : table) {
    if (s.t > 10.0 && s.t < 10.3) s.angles_deg[1] = table[1000].angles_deg[1];
  }
  // Re-continue after the pause with the same offset so only a pause is introduced.
  const auto segs = io::deriveSegments(calib::TableKind::kTwoAxis, table);
  ASSERT_GE(segs.size(), 2u);
  EXPECT_EQ(segs[1].kind, calib::SegmentKind::kRotate);
  EXPECT_NEAR(segs[1].t1, 23.0, 0.011);
}

TEST(DeriveSegments, ReadUsesDerivedSegmentsWhenFileAbsent) {
  ScratchDir dir("rec-derive");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("imu.csv"), kGoodImu);
  std::ostringstream t;
  t << "t,outer,inner\n";
  for (const auto& s : syntheticTable())
    t << s.t << ',' << s.angles_deg[0] << ',' << s.angles_deg[1] << '\n';
  writeText(dir.file("table.csv"), t.str());
  const auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(r.value.segments.size(), 5u);
  EXPECT_EQ(r.value.segments[1].kind, calib::SegmentKind::kRotate);
  EXPECT_NEAR(r.value.segments[1].angle, kPi, 1e-6);
}

TEST(DeriveSegments, RotateAxisFilledFromTableWhenSegmentsFileGiven) {
  ScratchDir dir("rec-segfile");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("imu.csv"), kGoodImu);
  std::ostringstream t;
  t.precision(17);
  t << "t,outer,inner\n";
  for (const auto& s : syntheticTable())
    t << s.t << ',' << s.angles_deg[0] << ',' << s.angles_deg[1] << '\n';
  writeText(dir.file("table.csv"), t.str());
  writeText(dir.file("segments.csv"),
            "t0,t1,kind,label\n0,4.9,static,\"A, up\"\n4.95,23.05,rotate,Z180\n");
  const auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(r.value.segments.size(), 2u);
  EXPECT_EQ(r.value.segments[0].label, "A, up");
  EXPECT_EQ(r.value.segments[1].axis, 1);
  EXPECT_NEAR(r.value.segments[1].angle, kPi, 1e-6);
}

TEST(DeriveSegments, OptionsValidation) {
  io::SegmentDerivationOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.still_rate_deg_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("still_rate_deg_s"), std::string::npos);
}

}  // namespace
}  // namespace imubench::daemon

namespace imubench::daemon {
namespace {

// imu.csv above the parallel-parse threshold (tens of MB): errors anywhere, including right at
// the chunk boundaries (which depend on the thread count), get the right line number.
class LargeImuCsv : public ::testing::Test {
 protected:
  static constexpr int kRows = 240000;  // fixed-length rows of 61 bytes: ~14.6 MB
  static std::string row(double t) {
    char buf[96];
    std::snprintf(buf, sizeof(buf), "%010.4f,1.25e-06,-2.5e-07,3.5e-06,0.001,-0.002,0.0981,25.5\n",
                  t);
    return buf;
  }
  std::string text(int bad_line, const std::string& bad_row) const {
    std::string s = "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n";
    s.reserve(static_cast<size_t>(kRows) * 64);
    for (int k = 1; k <= kRows; ++k) s += (k + 1 == bad_line) ? bad_row : row(k * 0.0005);
    return s;
  }
};

TEST_F(LargeImuCsv, ReadsAllRowsInOrder) {
  ScratchDir dir("rec-large-ok");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("table.csv"), kGoodTable);
  writeText(dir.file("imu.csv"), text(-1, ""));
  const auto r = io::readRecording(dir.str());
  ASSERT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(r.value.imu.size(), static_cast<size_t>(kRows));
  for (int k = 0; k < kRows; ++k)
    ASSERT_DOUBLE_EQ(r.value.imu[static_cast<size_t>(k)].t, (k + 1) * 0.0005);
  EXPECT_DOUBLE_EQ(r.value.imu.back().temp_c, 25.5);
}

TEST_F(LargeImuCsv, ErrorsNameTheirLineAcrossChunks) {
  ScratchDir dir("rec-large-bad");
  writeText(dir.file("meta.json"), kGoodMeta);
  writeText(dir.file("table.csv"), kGoodTable);
  // Lines around the chunk boundaries for 2, 3 and 4 threads (halves, thirds, quarters).
  std::vector<int> lines;
  for (int parts = 2; parts <= 4; ++parts) {
    for (int i = 1; i < parts; ++i) {
      const int mid = 1 + kRows * i / parts;
      for (int d = -1; d <= 2; ++d) lines.push_back(mid + d);
    }
  }
  for (int line : {lines[0], lines[1], lines[2], lines[3]}) {
    writeText(dir.file("imu.csv"), text(line, "12x,0,0,0,0,0,0,\n"));
    const auto r = io::readRecording(dir.str());
    ASSERT_FALSE(r.status.ok);
    EXPECT_EQ(r.status.message, dir.file("imu.csv") + ":" + std::to_string(line) +
                                    ": column 't': not a number '12x'");
  }
  for (int line : lines) {
    // Time steps back to 0 at this line.
    writeText(dir.file("imu.csv"), text(line, row(0.0)));
    const auto r = io::readRecording(dir.str());
    ASSERT_FALSE(r.status.ok);
    EXPECT_EQ(r.status.message.rfind(
                  dir.file("imu.csv") + ":" + std::to_string(line) + ": time 0 is not after", 0),
              0u)
        << r.status.message;
  }
}

}  // namespace
}  // namespace imubench::daemon
