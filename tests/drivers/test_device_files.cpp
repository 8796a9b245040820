// Device files: every shipped file loads; broken files are refused with file:line and reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "drivers/device_file.h"
#include "nav/rotation.h"
#include "virtual_bench_fixture.h"

namespace imubench::drivers {
namespace {

namespace fs = std::filesystem;
using testing::deviceDir;

TEST(DeviceFiles, EveryShippedTableFileLoads) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(deviceDir() + "/tables")) {
    if (e.path().extension() != ".toml") continue;
    io::Diagnostics diag(e.path().string());
    auto s = loadTableDevice(e.path().string(), diag);
    EXPECT_TRUE(s.has_value()) << diag.str();
    if (s) {
      EXPECT_GT(s->limits.max_rate, 0.0);
      EXPECT_GT(s->limits.max_accel, 0.0);
      ++n;
    }
  }
  EXPECT_GE(n, 3);
}

TEST(DeviceFiles, EveryShippedChamberFileLoads) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(deviceDir() + "/chambers")) {
    if (e.path().extension() != ".toml") continue;
    io::Diagnostics diag(e.path().string());
    auto s = loadChamberDevice(e.path().string(), diag);
    EXPECT_TRUE(s.has_value()) << diag.str();
    n += s.has_value();
  }
  EXPECT_GE(n, 2);
}

TEST(DeviceFiles, ReferenceTableValuesAreSi) {
  auto s = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  EXPECT_EQ(s.axisCount(), 2);
  EXPECT_EQ(s.transport.kind, TransportKind::kModbusTcp);
  EXPECT_NEAR(s.limits.max_rate, 300 * kDegToRad, 1e-12);
  EXPECT_NEAR(s.limits.max_jerk, 1000 * kDegToRad, 1e-9);
  EXPECT_NEAR(s.transport.retry.timeout_s, 0.3, 1e-12);
  EXPECT_EQ(s.registers.axes[1].position.address, 38);
  EXPECT_NEAR(s.registers.axes[1].position.lsb, kDegToRad, 1e-15);
  auto g = testing::tableSpec("generic-3axis-rtu.toml");
  EXPECT_EQ(g.axisCount(), 3);
  EXPECT_EQ(g.registers.word_order, WordOrder::kLowFirst);
  EXPECT_EQ(g.transport.parity, 'E');
  EXPECT_NEAR(g.registers.axes[2].position.lsb, 1e-4 * kDegToRad, 1e-18);
  EXPECT_EQ(g.registers.axes[2].position.bank, RegisterBank::kInput);
  auto c = testing::chamberSpec("watlow-f4-style.toml");
  EXPECT_EQ(c.registers.temperature.address, 100);
  EXPECT_EQ(c.registers.setpoint.address, 300);
  EXPECT_NEAR(c.registers.setpoint.lsb, 0.1, 1e-12);
  EXPECT_NEAR(c.max_ramp, 5.0 / 60.0, 1e-12);
}

// A valid minimal table file; each broken case edits one line of it.
const char* kGood = R"(
[device]
kind = "table"
vendor = "t"
model = "m"
axes = 2
[transport]
type = "serial-scpi"
device = "/dev/null"
baud = 9600
timeout = "100 ms"
[limits]
max_rate = "100 deg/s"
max_accel = "10 deg/s^2"
[commands]
angle_unit = "deg"
rate_unit = "deg/s"
ack = "OK"
mode_off = "A{axis}:OFF"
mode_position = "A{axis}:POS"
mode_rate = "A{axis}:RATE"
demand_position = "A{axis}:P {value}"
demand_rate = "A{axis}:R {value}"
rotate = "A{axis}:ROT {value}"
stop = "A{axis}:STOP"
estop = "ESTOP"
read_position = "A{axis}:P?"
read_rate = "A{axis}:R?"
read_status = "S?"
read_axis_status = "A{axis}:S?"
interlock_close = "IC"
interlock_open = "IO"
interlock_reset = "IR"
)";

std::string replaceLine(const std::string& text, const std::string& from, const std::string& to) {
  std::string s = text;
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

int lineOf(const std::string& text, const std::string& needle) {
  const auto p = text.find(needle);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(p), '\n'));
}

TEST(DeviceFiles, GoodBaseLoads) {
  io::Diagnostics diag("good.toml");
  EXPECT_TRUE(parseTableDevice(kGood, diag).has_value()) << diag.str();
}

struct BrokenCase {
  const char* from;
  const char* to;
  const char* reason;  // substring of the diagnostic
};

TEST(DeviceFiles, BrokenTableFilesAreRefusedWithLineAndReason) {
  const BrokenCase cases[] = {
      {"max_rate = \"100 deg/s\"", "max_rate = 100", "missing unit"},
      {"max_rate = \"100 deg/s\"", "max_rate = \"100 deg\"", "wrong unit"},
      {"max_accel = \"10 deg/s^2\"", "max_accel = \"-10 deg/s^2\"", "must be positive"},
      {"timeout = \"100 ms\"", "timeout = \"100 parsecs\"", "unknown unit"},
      {"type = \"serial-scpi\"", "type = \"carrier-pigeon\"", "unknown transport type"},
      {"baud = 9600", "baud = 12345", "unsupported baud rate"},
      {"axes = 2", "axes = 5", "out of range"},
      {"rotate = \"A{axis}:ROT {value}\"", "rotate = \"A{axis}:ROT\"", "must contain {value}"},
      {"estop = \"ESTOP\"", "estop = \"ESTOP {axis}\"", "must not contain {axis}"},
      {"ack = \"OK\"", "akc = \"OK\"", "unknown key \"akc\""},
      {"model = \"m\"", "model = \"m", "string"},  // TOML syntax error (unterminated string)
      {"angle_unit = \"deg\"", "angle_unit = \"furlong\"", "unknown unit"},
  };
  for (const auto& c : cases) {
    const std::string text = replaceLine(kGood, c.from, c.to);
    io::Diagnostics diag("broken.toml");
    EXPECT_FALSE(parseTableDevice(text, diag).has_value()) << c.to;
    ASSERT_FALSE(diag.ok()) << c.to;
    const auto& d = diag.items().front();
    EXPECT_EQ(d.line, lineOf(text, c.to)) << c.to << " -> " << d.str();
    EXPECT_NE(d.message.find(c.reason), std::string::npos) << c.to << " -> " << d.str();
    EXPECT_EQ(d.str().rfind("broken.toml:" + std::to_string(d.line) + ":", 0), 0u) << d.str();
  }
}

// Every shipped table file says where the driver puts a motion's rate and acceleration: a
// table without it would run a plan at its controller's own (fastest) profile.
TEST(DeviceFiles, EveryShippedTableFileCanSetTheMotionProfile) {
  for (const auto& e : fs::directory_iterator(deviceDir() + "/tables")) {
    if (e.path().extension() != ".toml") continue;
    io::Diagnostics diag(e.path().string());
    auto s = loadTableDevice(e.path().string(), diag);
    ASSERT_TRUE(s.has_value()) << diag.str();
    EXPECT_TRUE(s->profileSettable()) << e.path();
  }
  const auto ref = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  EXPECT_EQ(ref.registers.axes[1].rate_limit.address, 44);
  EXPECT_NEAR(ref.registers.axes[1].accel_limit.lsb, kDegToRad, 1e-15);  // f32 in deg/s^2
  const auto serial = testing::tableSpec("scpi-2axis-serial.toml");
  EXPECT_NEAR(serial.commands.accel_unit, kDegToRad, 1e-15);
  EXPECT_EQ(serial.commands.set_accel_limit.text, "AXIS{axis}:ACC {value}");
}

TEST(DeviceFiles, MotionProfileCommandsAreBothOrNeitherWithLineAndReason) {
  const std::string with = std::string(kGood) +
                           "accel_unit = \"deg/s^2\"\n"
                           "set_rate_limit = \"A{axis}:VEL {value}\"\n"
                           "set_accel_limit = \"A{axis}:ACC {value}\"\n";
  {
    io::Diagnostics diag("good.toml");
    auto s = parseTableDevice(with, diag);
    ASSERT_TRUE(s.has_value()) << diag.str();
    EXPECT_TRUE(s->profileSettable());
    io::Diagnostics diag2("without.toml");
    auto without = parseTableDevice(kGood, diag2);
    ASSERT_TRUE(without.has_value());
    EXPECT_FALSE(without->profileSettable());  // loads, but cannot follow a plan's profile
  }
  const BrokenCase cases[] = {
      {"set_accel_limit = \"A{axis}:ACC {value}\"\n", "", "give both"},
      {"set_rate_limit = \"A{axis}:VEL {value}\"", "set_rate_limit = \"A{axis}:VEL\"",
       "must contain {value}"},
      {"set_accel_limit = \"A{axis}:ACC {value}\"", "set_accel_limit = \"ACC {value}\"",
       "must contain {axis}"},
      {"accel_unit = \"deg/s^2\"", "accel_unit = \"deg/s\"", "unit"},
  };
  for (const auto& c : cases) {
    const std::string text = replaceLine(with, c.from, c.to);
    io::Diagnostics diag("broken.toml");
    EXPECT_FALSE(parseTableDevice(text, diag).has_value()) << c.to;
    ASSERT_FALSE(diag.ok()) << c.to;
    const auto& d = diag.items().front();
    const std::string at = *c.to != '\0' ? c.to : "set_rate_limit";
    EXPECT_EQ(d.line, lineOf(text, at)) << c.to << " -> " << d.str();
    EXPECT_NE(d.str().find(c.reason), std::string::npos) << c.to << " -> " << d.str();
  }
  // accel_unit is required with set_accel_limit.
  io::Diagnostics diag("no-unit.toml");
  const std::string no_unit = replaceLine(with, "accel_unit = \"deg/s^2\"\n", "");
  EXPECT_FALSE(parseTableDevice(no_unit, diag).has_value());
  EXPECT_NE(diag.str().find("needs \"accel_unit\""), std::string::npos) << diag.str();
  EXPECT_NE(diag.str().find("no-unit.toml:" + std::to_string(lineOf(no_unit, "set_accel_limit"))),
            std::string::npos)
      << diag.str();
}

TEST(DeviceFiles, MotionProfileRegistersAreBothOrNeither) {
  const std::string path = deviceDir() + "/tables/imubench-ref-2axis-tcp.toml";
  std::string ref;
  {
    std::ifstream in(path);
    std::ostringstream ss;
    ss << in.rdbuf();
    ref = ss.str();
  }
  const std::string accel1 = "accel_limit = { address = 46, type = \"f32\", unit = \"deg/s^2\" }";
  const BrokenCase cases[] = {
      {accel1.c_str(), "", "give both \"rate_limit\" and \"accel_limit\""},
      {accel1.c_str(), "accel_limit = { address = 46, type = \"f32\", unit = \"deg/s\" }",
       "wrong unit"},
      {accel1.c_str(), "accel_limit = { address = 43, type = \"f32\", unit = \"deg/s^2\" }",
       "overlap"},
  };
  for (const auto& c : cases) {
    io::Diagnostics diag("broken-map.toml");
    EXPECT_FALSE(parseTableDevice(replaceLine(ref, c.from, c.to), diag).has_value()) << c.to;
    EXPECT_NE(diag.str().find(c.reason), std::string::npos) << c.to << " -> " << diag.str();
    EXPECT_NE(diag.str().find("broken-map.toml:"), std::string::npos) << diag.str();
  }
}

// [host_watchdog]: a holding register for the heartbeat and a timeout (default 0.5 s);
// refused with line and reason where it cannot work.
TEST(DeviceFiles, HostWatchdogIsDeclaredInModbusFilesOnly) {
  const auto ref = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  ASSERT_TRUE(ref.watchdog.declared());
  EXPECT_EQ(ref.watchdog.heartbeat.address, 2);
  EXPECT_EQ(ref.watchdog.heartbeat.bank, RegisterBank::kHolding);
  EXPECT_NEAR(ref.watchdog.timeout_s, 0.5, 1e-12);
  EXPECT_FALSE(testing::tableSpec("scpi-2axis-serial.toml").watchdog.declared());
  const std::string path = deviceDir() + "/tables/imubench-ref-2axis-tcp.toml";
  std::string text;
  {
    std::ifstream in(path);
    std::ostringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const std::string hb = "heartbeat = { address = 2, type = \"u16\" }";
  {  // the timeout left out: 0.5 s
    io::Diagnostics diag("default.toml");
    const auto s = parseTableDevice(replaceLine(text, "timeout = \"500 ms\"\n", ""), diag);
    ASSERT_TRUE(s.has_value()) << diag.str();
    EXPECT_NEAR(s->watchdog.timeout_s, 0.5, 1e-12);
  }
  const BrokenCase cases[] = {
      {hb.c_str(), "heartbeat = { address = 2, type = \"u16\", bank = \"input\" }",
       "must be a holding register"},
      {hb.c_str(), "heartbeat = { address = 2, type = \"f32\", unit = \"deg\" }", "no unit/lsb"},
      {hb.c_str(), "heartbeat = { address = 1, type = \"u16\" }", "overlap"},
      {"timeout = \"500 ms\"\n", "timeout = \"0 s\"\n", "must be in (0, 60] s"},
      {hb.c_str(), "heartbeet = 2", "unknown key \"heartbeet\""},
  };
  for (const auto& c : cases) {
    io::Diagnostics diag("broken-watchdog.toml");
    EXPECT_FALSE(parseTableDevice(replaceLine(text, c.from, c.to), diag).has_value()) << c.to;
    EXPECT_NE(diag.str().find(c.reason), std::string::npos) << c.to << " -> " << diag.str();
    EXPECT_NE(diag.str().find("broken-watchdog.toml:"), std::string::npos) << diag.str();
  }
  // A serial command set has no heartbeat command: refused at the section's line.
  const std::string serial = std::string(kGood) + "[host_watchdog]\ntimeout = \"1 s\"\n";
  io::Diagnostics diag("serial.toml");
  EXPECT_FALSE(parseTableDevice(serial, diag).has_value());
  EXPECT_NE(diag.str().find("serial-scpi command set has no heartbeat"), std::string::npos)
      << diag.str();
}

TEST(DeviceFiles, BrokenRegisterMapsAreRefused) {
  const std::string base = R"(
[device]
kind = "chamber"
vendor = "v"
model = "m"
[transport]
type = "modbus-tcp"
timeout = "1 s"
[limits]
temperature_min = "-40 degC"
temperature_max = "85 degC"
max_ramp = "5 degC/min"
[registers]
word_order = "high-first"
temperature = { address = 100, type = "i16", lsb = "0.1 degC" }
setpoint = { address = 300, type = "i16", lsb = "0.1 degC" }
ramp_rate = { address = 310, type = "u16", lsb = "0.01 degC/min" }
run = { address = 320, type = "u16" }
alarms = { address = 330, type = "u16" }
)";
  {
    io::Diagnostics diag("ok.toml");
    EXPECT_TRUE(parseChamberDevice(base, diag).has_value()) << diag.str();
  }
  const BrokenCase cases[] = {
      {"type = \"i16\", lsb = \"0.1 degC\" }\nsetpoint",
       "type = \"f16\", lsb = \"0.1 degC\" }\nsetpoint", "unknown register type"},
      {"run = { address = 320, type = \"u16\" }",
       "run = { address = 320, type = \"u16\", lsb = \"1 degC\" }", "no unit/lsb"},
      {"setpoint = { address = 300, type = \"i16\", lsb = \"0.1 degC\" }",
       "setpoint = { address = 300, type = \"i16\", unit = \"degC\" }", "\"unit\" is for f32"},
      {"word_order = \"high-first\"", "word_order = \"middle-endian\"", "word_order must be"},
      {"address = 330", "address = 70000", "out of range"},
      {"temperature_max = \"85 degC\"", "temperature_max = \"-85 degC\"", "must be above"},
  };
  for (const auto& c : cases) {
    const std::string text = replaceLine(base, c.from, c.to);
    io::Diagnostics diag("broken-chamber.toml");
    EXPECT_FALSE(parseChamberDevice(text, diag).has_value()) << c.to;
    ASSERT_FALSE(diag.ok());
    const auto& d = diag.items().front();
    EXPECT_EQ(d.line, lineOf(text, c.to)) << c.to << " -> " << d.str();
    EXPECT_NE(d.message.find(c.reason), std::string::npos) << c.to << " -> " << d.str();
  }
  // Overlapping registers are reported (at the [registers] table).
  io::Diagnostics diag("overlap.toml");
  EXPECT_FALSE(parseChamberDevice(replaceLine(base, "address = 320", "address = 300"), diag));
  EXPECT_NE(diag.str().find("overlap at address 300"), std::string::npos) << diag.str();
  // A table file given where a chamber is expected says so.
  io::Diagnostics kind("kind.toml");
  EXPECT_FALSE(
      parseChamberDevice(replaceLine(base, "kind = \"chamber\"", "kind = \"table\""), kind));
  EXPECT_NE(kind.str().find("expected kind = \"chamber\""), std::string::npos) << kind.str();
  // A missing file names the file.
  io::Diagnostics missing("/nonexistent/device.toml");
  EXPECT_FALSE(loadTableDevice("/nonexistent/device.toml", missing));
  EXPECT_NE(missing.str().find("/nonexistent/device.toml: cannot open"), std::string::npos);
}

}  // namespace
}  // namespace imubench::drivers
