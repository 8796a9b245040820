#include "daemon/bench_file.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

const std::string kSource = IMUBENCH_SOURCE_DIR;
const std::string kBenchDir = kSource + "/daemon/benches";

// A complete bench with every section; tests replace one line to break it.
const std::string kGood = R"([bench]
name = "lab2-a"
storage = "state/imubench.db"
control_socket = "/run/imubench/control.sock"

[site]
latitude = "55.7558 deg"
height = "150 m"
gravity_mps2 = 9.8155

[table]
device = "../../drivers/devices/tables/imubench-ref-2axis-tcp.toml"
host = "10.0.0.20"
port = 5020
max_rate = "30 deg/s"

[chamber]
device = "../../drivers/devices/chambers/watlow-f4-style.toml"
safe_setpoint = "25 degC"

[imu]
layout = "../../drivers/devices/imus/sbg_ecan.toml"
interface = "can1"

[safety]
imu_timeout = "0.2 s"
)";

std::string replaced(const std::string& from, const std::string& to) {
  std::string s = kGood;
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

std::optional<BenchConfig> parse(const std::string& text, io::Diagnostics& diag) {
  return parseBenchFile(text, "bench.toml", kBenchDir, diag);
}

TEST(BenchFile, ShippedVirtualBenchLoads) {
  io::Diagnostics diag(kBenchDir + "/virtual-bench.toml");
  const auto b = loadBenchFile(diag.file(), diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_EQ(b->name, "virtual-bench");
  EXPECT_NEAR(b->site.latitude_rad * kRadToDeg, 55.7558, 1e-12);
  EXPECT_EQ(b->table.transport.port, 1502);
  EXPECT_NEAR(b->table.limits.max_rate * kRadToDeg, 30.0, 1e-12);  // tightened from 300
  ASSERT_TRUE(b->chamber.has_value());
  EXPECT_EQ(b->chamber->device.transport.port, 1503);
  EXPECT_EQ(b->imu.interface, "vcan0");
  EXPECT_FALSE(b->imu.layout.messages.empty());
  EXPECT_EQ(b->plan_dir, kSource + "/plans/library");
}

TEST(BenchFile, EveryFieldReadAndPathsResolvedAgainstTheBenchFile) {
  io::Diagnostics diag("bench.toml");
  const auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_EQ(b->storage_path, kBenchDir + "/state/imubench.db");
  EXPECT_EQ(b->control_socket, "/run/imubench/control.sock");
  EXPECT_EQ(b->table.transport.host, "10.0.0.20");
  EXPECT_EQ(b->table.transport.port, 5020);
  EXPECT_NEAR(b->table.limits.max_accel * kRadToDeg, 100.0, 1e-9);  // device's, not overridden
  ASSERT_TRUE(b->site.gravity_mps2.has_value());
  EXPECT_DOUBLE_EQ(*b->site.gravity_mps2, 9.8155);
  EXPECT_NEAR(b->outer_axis_heading_rad * kRadToDeg, 90.0, 1e-12);
  EXPECT_DOUBLE_EQ(b->chamber->safe_setpoint_c, 25.0);
  EXPECT_DOUBLE_EQ(b->chamber->over_temperature_c, 90.0);
  EXPECT_DOUBLE_EQ(b->chamber->poll_period_s, 1.0);  // the default
  EXPECT_EQ(b->imu.interface, "can1");
  EXPECT_DOUBLE_EQ(b->safety.imu_timeout_s, 0.2);
  EXPECT_DOUBLE_EQ(b->safety.comm_timeout_s, 1.0);
  EXPECT_DOUBLE_EQ(b->control.idle_timeout_s, 600.0);  // [control] absent: the default
}

TEST(BenchFile, ControlIdleTimeout) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood + "\n[control]\nidle_timeout = \"2.5 s\"\n", diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->control.idle_timeout_s, 2.5);
  b = parse(kGood + "\n[control]\nidle_timeout = \"0 s\"\n", diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->control.idle_timeout_s, 0.0);
  io::Diagnostics bad("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[control]\nidle_timeout = \"-1 s\"\n", bad).has_value());
  EXPECT_NE(bad.str().find("idle_timeout must be in [0, "), std::string::npos) << bad.str();
  io::Diagnostics typo("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[control]\nidle = \"1 s\"\n", typo).has_value());
  EXPECT_NE(typo.str().find("unknown key \"idle\" in [control]"), std::string::npos) << typo.str();
}

// Issue 30: [lab] names the lab database; a password in its URI is refused at its line and
// never repeated in the diagnostic; the password file resolves against the bench file.
TEST(BenchFile, LabDatabaseWithoutCredentials) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood +
                     "\n[lab]\ndatabase = \"postgresql://bench1@127.0.0.1:5433/lab\"\n"
                     "password_file = \"lab.pass\"\n",
                 diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  ASSERT_TRUE(b->lab.has_value());
  EXPECT_EQ(b->lab->database, "postgresql://bench1@127.0.0.1:5433/lab");
  EXPECT_EQ(b->lab->password_file, std::string(kBenchDir) + "/lab.pass");
  EXPECT_FALSE(parse(kGood, diag)->lab.has_value());
  io::Diagnostics bad("bench.toml");
  EXPECT_FALSE(
      parse(kGood + "\n[lab]\ndatabase = \"postgresql://bench1:hunter2@127.0.0.1/lab\"\n", bad)
          .has_value());
  EXPECT_NE(bad.str().find("carries a password"), std::string::npos) << bad.str();
  EXPECT_EQ(bad.str().find("hunter2"), std::string::npos) << bad.str();
  io::Diagnostics typo("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[lab]\ndatabase = \"postgresql:///lab\"\npassword = \"x\"\n", typo)
                   .has_value());
  EXPECT_NE(typo.str().find("unknown key \"password\" in [lab]"), std::string::npos) << typo.str();
}

// [lab] mirror_samples: default false; true or false only, refused at its line otherwise.
TEST(BenchFile, LabMirrorSamples) {
  const std::string lab = kGood + "\n[lab]\ndatabase = \"postgresql://bench1@127.0.0.1/lab\"\n";
  io::Diagnostics diag("bench.toml");
  auto off = parse(lab, diag);
  ASSERT_TRUE(off.has_value()) << diag.str();
  EXPECT_FALSE(off->lab->mirror_samples);
  auto on = parse(lab + "mirror_samples = true\n", diag);
  ASSERT_TRUE(on.has_value()) << diag.str();
  EXPECT_TRUE(on->lab->mirror_samples);
  io::Diagnostics bad("bench.toml");
  EXPECT_FALSE(parse(lab + "mirror_samples = \"yes\"\n", bad).has_value());
  const std::string line =
      "bench.toml:" + std::to_string(std::count(lab.begin(), lab.end(), '\n') + 1) + ":";
  EXPECT_NE(bad.str().find(line), std::string::npos) << bad.str();
  EXPECT_NE(bad.str().find("mirror_samples"), std::string::npos) << bad.str();
}

// Issue 27 item 3: [explain] follow_up, default "propose"; another value is refused at its
// line with the values it may take.
TEST(BenchFile, ExplainFollowUpPolicy) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_EQ(b->explain.follow_up, FollowUpPolicy::kPropose);
  for (const char* v : {"off", "propose", "queue"}) {
    b = parse(kGood + "\n[explain]\nfollow_up = \"" + v + "\"\n", diag);
    ASSERT_TRUE(b.has_value()) << diag.str();
    EXPECT_STREQ(followUpPolicyName(b->explain.follow_up), v);
  }
  io::Diagnostics bad("bench.toml");
  const std::string text = kGood + "\n[explain]\nfollow_up = \"always\"\n";
  EXPECT_FALSE(parse(text, bad).has_value());
  const int line = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  EXPECT_NE(bad.str().find("bench.toml:" + std::to_string(line) + ":"), std::string::npos)
      << bad.str();
  EXPECT_NE(bad.str().find("follow_up must be \"off\", \"propose\" or \"queue\""),
            std::string::npos)
      << bad.str();
  io::Diagnostics typo("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[explain]\nfollowup = \"off\"\n", typo).has_value());
  EXPECT_NE(typo.str().find("unknown key \"followup\" in [explain]"), std::string::npos)
      << typo.str();
}

// Issue 28 item 7: the gap in the table readings that re-runs a step, default 0.2 s.
TEST(BenchFile, TableReadingGap) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->table_reading_gap_s, 0.2);
  b = parse(replaced("max_rate = \"30 deg/s\"", "max_rate = \"30 deg/s\"\nreading_gap = \"1.5 s\""),
            diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->table_reading_gap_s, 1.5);
  io::Diagnostics bad("bench.toml");
  EXPECT_FALSE(
      parse(replaced("max_rate = \"30 deg/s\"", "max_rate = \"30 deg/s\"\nreading_gap = \"0 s\""),
            bad)
          .has_value());
  EXPECT_NE(bad.str().find("bench.toml:"), std::string::npos) << bad.str();
  EXPECT_NE(bad.str().find("reading_gap must be in (0, 60] s"), std::string::npos) << bad.str();
}

// [table] errors: the table's certified errors (a coefficient file's "table"), of the table
// device's kind; unset by default.
TEST(BenchFile, TableErrorsFromACertificationFile) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_FALSE(b->table_errors.has_value());
  const std::string with = "max_rate = \"30 deg/s\"\nerrors = \"../../tests/tools/data/";
  b = parse(replaced("max_rate = \"30 deg/s\"", with + "truth_nav_grade.json\""), diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  ASSERT_TRUE(b->table_errors.has_value());
  EXPECT_DOUBLE_EQ(b->table_errors->base_tilt.x(), 5e-5);
  EXPECT_DOUBLE_EQ(b->table_errors->nonorthogonality.inner_y, 7e-5);
  EXPECT_NE(b->table_errors_file.find("truth_nav_grade.json"), std::string::npos);
  for (const auto& [file, why] : std::vector<std::pair<std::string, std::string>>{
           {"truth_three_axis.json", "holds three-axis table errors, the table device is two-axis"},
           {"no_such_file.json", "no_such_file.json"}}) {
    io::Diagnostics bad("bench.toml");
    EXPECT_FALSE(parse(replaced("max_rate = \"30 deg/s\"", with + file + "\""), bad).has_value());
    EXPECT_NE(bad.str().find("bench.toml:"), std::string::npos) << bad.str();
    EXPECT_NE(bad.str().find(why), std::string::npos) << bad.str();
  }
}

// [imu] max_clock_ratio: the decoder's (and the crash resume's) clock ratio; default 2.
TEST(BenchFile, ImuMaxClockRatio) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->imu.max_clock_ratio, 2.0);
  const auto with = [](const std::string& line) {
    return replaced("interface = \"can1\"", "interface = \"can1\"\n" + line);
  };
  b = parse(with("max_clock_ratio = 25"), diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->imu.max_clock_ratio, 25.0);
  for (const char* bad :
       {"max_clock_ratio = 0", "max_clock_ratio = 2.5", "max_clock_ratio = 5000"}) {
    io::Diagnostics d("bench.toml");
    EXPECT_FALSE(parse(with(bad), d).has_value()) << bad;
    EXPECT_NE(d.str().find("max_clock_ratio"), std::string::npos) << d.str();
  }
}

// Issue 28: connections per uid and the stop socket.
TEST(BenchFile, ControlConnectionsPerUidAndStopSocket) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_EQ(b->control.max_connections_per_uid, 4u);
  EXPECT_EQ(b->control.stop_socket, "");  // the daemon uses control_socket + ".stop"
  b = parse(kGood + "\n[control]\nmax_connections_per_uid = 0\nstop_socket = \"/run/x/stop\"\n",
            diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_EQ(b->control.max_connections_per_uid, 0u);
  EXPECT_EQ(b->control.stop_socket, "/run/x/stop");
  for (const char* bad : {"max_connections_per_uid = -1", "max_connections_per_uid = 1.5",
                          "max_connections_per_uid = 100000", "stop_socket = \"\"",
                          "stop_socket = \"/run/imubench/control.sock\"", "stop_socket = 3"}) {
    io::Diagnostics d("bench.toml");
    EXPECT_FALSE(parse(kGood + "\n[control]\n" + bad + "\n", d).has_value()) << bad;
    EXPECT_NE(d.str().find("bench.toml:"), std::string::npos) << d.str();
  }
}

TEST(BenchFile, ControlGroupsResolvedAtLoad) {
  io::Diagnostics diag("bench.toml");
  auto b = parse(kGood, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_FALSE(b->control.command_group.has_value());  // absent: no rights checked
  EXPECT_FALSE(b->control.read_group.has_value());
  b = parse(kGood + "\n[control]\ncommand_group = \"root\"\nread_group = \"daemon\"\n", diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  ASSERT_TRUE(b->control.command_group.has_value());
  EXPECT_EQ(b->control.command_group->name, "root");
  EXPECT_EQ(b->control.command_group->gid, 0u);
  ASSERT_TRUE(b->control.read_group.has_value());
  EXPECT_EQ(b->control.read_group->name, "daemon");
  // An unknown group: file:line at its key.
  io::Diagnostics unknown("bench.toml");
  EXPECT_FALSE(
      parse(kGood + "\n[control]\ncommand_group = \"no-such-group-x\"\n", unknown).has_value());
  EXPECT_NE(unknown.str().find("bench.toml:29:"), std::string::npos) << unknown.str();
  EXPECT_NE(unknown.str().find("command_group: no group \"no-such-group-x\" on this system"),
            std::string::npos)
      << unknown.str();
  io::Diagnostics alone("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[control]\nread_group = \"root\"\n", alone).has_value());
  EXPECT_NE(alone.str().find("read_group needs command_group"), std::string::npos) << alone.str();
}

TEST(BenchFile, ChamberPollPeriod) {
  io::Diagnostics diag("bench.toml");
  const auto b = parse(replaced("safe_setpoint = \"25 degC\"",
                                "safe_setpoint = \"25 degC\"\npoll_period = \"250 ms\""),
                       diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_DOUBLE_EQ(b->chamber->poll_period_s, 0.25);
}

TEST(BenchFile, ChamberIsOptional) {
  std::string text = kGood;
  const auto from = text.find("[chamber]");
  const auto to = text.find("[imu]");
  text.erase(from, to - from);
  io::Diagnostics diag("bench.toml");
  const auto b = parse(text, diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  EXPECT_FALSE(b->chamber.has_value());
}

struct BadCase {
  const char* name;
  std::string text;
  const char* expected;  // part of the diagnostic
  int line;              // line it must name (0: do not check)
};

class BenchFileRefuses : public ::testing::TestWithParam<BadCase> {};

TEST_P(BenchFileRefuses, WithFileLineAndReason) {
  const BadCase& c = GetParam();
  io::Diagnostics diag("bench.toml");
  EXPECT_FALSE(parse(c.text, diag).has_value());
  const std::string msg = diag.str();
  EXPECT_NE(msg.find(c.expected), std::string::npos) << msg;
  EXPECT_NE(msg.find("bench.toml"), std::string::npos) << msg;
  if (c.line > 0) {
    EXPECT_NE(msg.find("bench.toml:" + std::to_string(c.line) + ":"), std::string::npos) << msg;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BenchFileRefuses,
    ::testing::Values(
        BadCase{"not_toml", "[bench", "", 1},
        BadCase{"unknown_key", replaced("height = \"150 m\"", "heigth = \"150 m\""),
                "unknown key \"heigth\" in [site]", 8},
        BadCase{"bare_number", replaced("\"55.7558 deg\"", "55.7558"), "missing unit", 7},
        BadCase{"latitude_range", replaced("55.7558 deg", "95 deg"), "latitude", 7},
        BadCase{"gravity_range", replaced("9.8155", "98.155"), "gravity_mps2", 9},
        BadCase{"looser_rate", replaced("\"30 deg/s\"", "\"400 deg/s\""),
                "looser than the device file's 300 deg/s", 15},
        BadCase{"negative_rate", replaced("\"30 deg/s\"", "\"-3 deg/s\""), "positive", 15},
        BadCase{"port_range", replaced("5020", "70000"), "out of range", 14},
        BadCase{"missing_table_device", replaced("tables/imubench-ref-2axis-tcp", "tables/none"),
                "cannot open device file", 12},
        BadCase{"missing_imu", replaced("[imu]", "[imu_typo]"), "unknown key \"imu_typo\"", 0},
        BadCase{"missing_imu_table", replaced("[imu]", "[imu_typo]"),
                "missing required table [imu]", 0},
        BadCase{"safe_setpoint_range", replaced("\"25 degC\"", "\"500 degC\""),
                "safe_setpoint is outside", 0},
        BadCase{"poll_period_range",
                replaced("safe_setpoint = \"25 degC\"",
                         "safe_setpoint = \"25 degC\"\npoll_period = \"0 s\""),
                "poll_period must be in [0.01, 60] s", 20},
        BadCase{"timeout_range", replaced("\"0.2 s\"", "\"0 s\""), "imu_timeout must be", 0},
        BadCase{"wrong_type", replaced("\"lab2-a\"", "3"), "\"name\" must be a string", 2}),
    [](const ::testing::TestParamInfo<BadCase>& tc) { return std::string(tc.param.name); });

TEST(BenchFile, UnreadableFileNamesIt) {
  io::Diagnostics diag("/nonexistent/bench.toml");
  EXPECT_FALSE(loadBenchFile(diag.file(), diag).has_value());
  EXPECT_NE(diag.str().find("/nonexistent/bench.toml"), std::string::npos) << diag.str();
  EXPECT_NE(diag.str().find("cannot open bench file"), std::string::npos) << diag.str();
}

TEST(BenchFile, AcceptanceLimitsInTheParametersDisplayUnits) {
  io::Diagnostics diag("bench.toml");
  const auto b = parse(kGood +
                           "\n[acceptance]\n\"gyro.bias\" = \"0.01 deg/h\"\n"
                           "\"accel.scale.x\" = \"100 ppm\"\n",
                       diag);
  ASSERT_TRUE(b.has_value()) << diag.str();
  ASSERT_EQ(b->acceptance.size(), 2u);  // in key order (TOML tables are unordered)
  EXPECT_EQ(b->acceptance[0].parameter, "accel.scale.x");
  EXPECT_NEAR(b->acceptance[0].limit, 1e-4, 1e-18);
  EXPECT_EQ(b->acceptance[1].parameter, "gyro.bias");
  EXPECT_NEAR(b->acceptance[1].limit, 0.01 * kDegToRad / 3600.0, 1e-20);
  EXPECT_EQ(b->acceptance[1].text, "0.01 deg/h");
}

TEST(BenchFile, AcceptanceRefusesUnknownParametersAndWrongUnits) {
  io::Diagnostics unit("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[acceptance]\n\"gyro.bias\" = \"0.01 ppm\"\n", unit));
  EXPECT_NE(unit.str().find("\"<limit> deg/h\""), std::string::npos) << unit.str();
  io::Diagnostics name("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[acceptance]\n\"gyro.bia\" = \"0.01 deg/h\"\n", name));
  EXPECT_NE(name.str().find("not a calibration parameter"), std::string::npos) << name.str();
  io::Diagnostics negative("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[acceptance]\n\"accel.bias\" = \"-5 ug\"\n", negative));
  io::Diagnostics number("bench.toml");
  EXPECT_FALSE(parse(kGood + "\n[acceptance]\n\"accel.bias\" = 5\n", number));
}

}  // namespace
}  // namespace imubench::daemon
