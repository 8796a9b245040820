// Driver <-> virtual device over the real protocols: Modbus TCP (127.0.0.1, ephemeral port,
// several clients), Modbus RTU on a pseudo-terminal, the SCPI-like serial command set on a
// pseudo-terminal; the chamber over Modbus TCP and RTU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "drivers/chamber.h"
#include "drivers/table.h"
#include "nav/rotation.h"
#include "virtual_bench_fixture.h"

namespace imubench::drivers {
namespace {

using testing::waitUntil;

// Waits until the axis is at rest in position and returns the last reading. The status and
// the angle may come from different transactions (a register block per poll on RTU), so the
// status can report "in position" while the angle read a moment earlier is still the end of
// the approach: at rest means two consecutive readings in position with the same angle.
TableReading settle(TableDriver& drv, int axis) {
  TableReading r;
  std::optional<double> previous;
  const bool ok = waitUntil([&] {
    const auto a = static_cast<size_t>(axis);
    if (!drv.read(&r).ok || !r.axes[a].in_position || r.axes[a].moving) {
      previous.reset();
      return false;
    }
    const bool same = previous && *previous == r.axes[a].angle;
    previous = r.axes[a].angle;
    return same;
  });
  EXPECT_TRUE(ok) << "axis " << axis << " did not settle";
  return r;
}

// Every executed phase of the axis turns one way (sign of the rates).
void expectTurnedOneWay(const calib::Motion& m, int axis, double sign) {
  for (const auto& p : m.axes[static_cast<size_t>(axis)].phases()) {
    EXPECT_GE(sign * p.rate0, -1e-12);
  }
}

class TableOverProtocols : public ::testing::Test {
 protected:
  // Moves the first axis by -180 deg, then +180 deg, then the last axis the short way to
  // 270 deg (= -90 deg), checking the world and the driver's readings.
  void exercise(VirtualWorld& world, TableDriver& drv, double tol) {
    ASSERT_TRUE(drv.connect().ok);
    ASSERT_TRUE(drv.interlock(InterlockCommand::kClose).ok);
    const int last = drv.spec().axisCount() - 1;
    Status s = drv.rotateBy(0, -kPi);
    ASSERT_TRUE(s.ok) << s.message;
    TableReading r = settle(drv, 0);
    EXPECT_NEAR(std::abs(r.axes[0].angle), kPi, tol);  // the controller reports +-180 deg
    calib::Motion m = world.motionSnapshot();
    EXPECT_NEAR(m.axes[0].at(m.duration).angle, -kPi, 1e-6);  // ... but it went the - way
    expectTurnedOneWay(m, 0, -1.0);
    const size_t phases_after_first = m.axes[0].phases().size();

    s = drv.rotateBy(0, kPi);
    ASSERT_TRUE(s.ok) << s.message;
    r = settle(drv, 0);
    EXPECT_NEAR(r.axes[0].angle, 0.0, tol);
    m = world.motionSnapshot();
    EXPECT_NEAR(m.axes[0].at(m.duration).angle, 0.0, 1e-6);
    for (size_t k = phases_after_first; k < m.axes[0].phases().size(); ++k) {
      EXPECT_GE(m.axes[0].phases()[k].rate0, -1e-12);  // back the + way
    }

    s = drv.moveTo(last, 270 * kDegToRad);
    ASSERT_TRUE(s.ok) << s.message;
    r = settle(drv, last);
    EXPECT_NEAR(r.axes[static_cast<size_t>(last)].angle, -90 * kDegToRad, tol);
    m = world.motionSnapshot();
    EXPECT_NEAR(m.axes[static_cast<size_t>(last)].at(m.duration).angle, -90 * kDegToRad, 1e-6);
    expectTurnedOneWay(m, last, -1.0);  // shortest way: -90, not +270
    EXPECT_EQ(drv.state(), DeviceState::kReady);
  }
  // Each axis' angle carries the instant it was read: inside the read, in the order read.
  static void expectReadInstants(TableDriver& drv) {
    TableReading r;
    const double before = unixTimeS();
    ASSERT_TRUE(drv.read(&r).ok);
    const double after = unixTimeS();
    double previous = before;
    for (const auto& a : r.axes) {
      EXPECT_GT(a.read_unix_s, previous);
      EXPECT_LT(a.read_unix_s, after);
      previous = a.read_unix_s;
    }
  }
  testing::EventLog log_;
  LinkFaults faults_;
};

TEST_F(TableOverProtocols, ModbusTcpSeveralClients) {
  auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  VirtualWorld world(spec, testing::chamberSpec("generic-float-chamber.toml"),
                     testing::kTestTimeScale);
  VirtualTableRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startTcp("127.0.0.1", 0).ok);
  ASSERT_GT(server.port(), 0);
  spec.transport.port = server.port();
  auto drv = makeTableDriver(spec, log_.sink());
  auto watcher = makeTableDriver(spec, log_.sink());  // a second client at the same time
  ASSERT_TRUE(watcher->connect().ok);
  exercise(world, *drv, 1e-5);
  TableReading r;
  ASSERT_TRUE(watcher->read(&r).ok);
  EXPECT_NEAR(r.axes[1].angle, -90 * kDegToRad, 1e-5);
  EXPECT_TRUE(waitUntil([&] { return server.clientCount() == 2; }));
  expectReadInstants(*drv);
}

// The host watchdog over Modbus TCP: every read (the daemon's poll) first writes a new
// heartbeat, which the controller sees change; once the reads stop, the controller opens its
// interlock after the device file's timeout (wall clock), and the next read re-arms it.
TEST_F(TableOverProtocols, EveryReadWritesTheHeartbeat) {
  auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  ASSERT_TRUE(spec.watchdog.declared());
  VirtualWorld world(spec, testing::chamberSpec("generic-float-chamber.toml"),
                     testing::kTestTimeScale);
  VirtualTableRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startTcp("127.0.0.1", 0).ok);
  spec.transport.port = server.port();
  auto drv = makeTableDriver(spec, log_.sink());
  ASSERT_TRUE(drv->connect().ok);
  ASSERT_TRUE(drv->interlock(InterlockCommand::kClose).ok);
  auto beats = [&] {
    return world.withTable([](VirtualTable& t, double) { return t.heartbeats(); });
  };
  EXPECT_EQ(beats(), 0u);
  TableReading r;
  for (std::uint64_t k = 1; k <= 10; ++k) {
    ASSERT_TRUE(drv->read(&r).ok);
    EXPECT_EQ(beats(), k) << "read " << k << " wrote no new heartbeat";
    EXPECT_TRUE(r.interlock_closed);
  }
  EXPECT_TRUE(world.withTable([](VirtualTable& t, double) { return t.watchdogArmed(); }));
  // No more reads: the interlock opens once the timeout has passed.
  EXPECT_TRUE(waitUntil([&] {
    return world.withTable([](VirtualTable& t, double now) {
      return (t.statusWord(now) & (1u << t.spec().bits.interlock_closed)) == 0;
    });
  }));
  ASSERT_TRUE(drv->read(&r).ok);
  EXPECT_FALSE(r.interlock_closed);
  EXPECT_EQ(world.withTable([](VirtualTable& t, double) { return t.watchdogExpiries(); }), 1);
  EXPECT_TRUE(world.withTable([](VirtualTable& t, double) { return t.watchdogArmed(); }));
  EXPECT_TRUE(log_.contains("host watchdog")) << log_.all();
}

// Modbus latency of 20 +- 5 ms per round trip, half each way (the virtual bench's
// --modbus-latency-ms/--modbus-jitter-ms): each axis' angle is stamped with the midpoint of
// its request and reply, the instant the controller read it, so a turning axis' reading is
// the world's angle at its stamp to the server's scheduling (ms); a stamp at the request or
// at the reply would be a half round trip, 10 ms, off (1 deg at 100 deg/s).
TEST_F(TableOverProtocols, ReadStampIsTheInstantTheControllerReadUnderLatency) {
  auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  VirtualWorld world(spec, testing::chamberSpec("generic-float-chamber.toml"), 1.0);
  VirtualTableRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startTcp("127.0.0.1", 0).ok);
  spec.transport.port = server.port();
  auto drv = makeTableDriver(spec, log_.sink());
  ASSERT_TRUE(drv->connect().ok);
  ASSERT_TRUE(drv->interlock(InterlockCommand::kClose).ok);
  const double rate = 100 * kDegToRad;
  ASSERT_TRUE(drv->setRate(0, rate).ok);
  const double at_rate = world.now() + 1.2;  // 1 s ramp at 100 deg/s^2
  TableReading r;
  ASSERT_TRUE(waitUntil([&] { return drv->read(&r).ok && world.now() > at_rate; }));
  faults_.latency_s = 0.020;
  faults_.jitter_s = 0.005;
  // The world's clock against the stamps' CLOCK_REALTIME (time scale 1).
  const double w0 = world.now(), u0 = unixTimeS();
  std::vector<double> errors;
  for (int k = 0; k < 15; ++k) {
    ASSERT_TRUE(drv->read(&r).ok);
    const calib::Motion m = world.motionSnapshot();
    const double t = w0 + (r.axes[0].read_unix_s - u0);
    errors.push_back(std::abs(std::remainder(r.axes[0].angle - m.axes[0].at(t).angle, 2 * kPi)));
  }
  std::sort(errors.begin(), errors.end());
  const double median_s = errors[errors.size() / 2] / rate;
  EXPECT_LT(median_s, 0.003) << "the stamp is " << median_s * 1e3 << " ms off the read";
  EXPECT_LT(errors.front() / rate, 0.003);
}

TEST_F(TableOverProtocols, ModbusRtuOnPseudoTerminal) {
  auto spec = testing::tableSpec("generic-3axis-rtu.toml");
  VirtualWorld world(spec, testing::chamberSpec("generic-float-chamber.toml"),
                     testing::kTestTimeScale);
  VirtualTableRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startRtu(spec.transport.unit_id).ok);
  spec.transport.device = server.ptyPath();
  auto drv = makeTableDriver(spec, log_.sink());
  exercise(world, *drv, 2e-4 * kDegToRad);  // i32 counts of 0.0001 deg
}

TEST_F(TableOverProtocols, SerialCommandSetOnPseudoTerminal) {
  auto spec = testing::tableSpec("scpi-2axis-serial.toml");
  VirtualWorld world(spec, testing::chamberSpec("generic-float-chamber.toml"),
                     testing::kTestTimeScale);
  VirtualTableScpi server(world, spec, faults_, log_.sink());
  ASSERT_TRUE(server.start().ok);
  spec.transport.device = server.ptyPath();
  auto drv = makeTableDriver(spec, log_.sink());
  exercise(world, *drv, 2e-6 * kDegToRad);  // 6 decimals of a degree
  expectReadInstants(*drv);
  // Rate mode over the serial line.
  ASSERT_TRUE(drv->setRate(1, 20 * kDegToRad).ok);
  TableReading r;
  EXPECT_TRUE(waitUntil(
      [&] { return drv->read(&r).ok && std::abs(r.axes[1].rate - 20 * kDegToRad) < 1e-6; }));
  ASSERT_TRUE(drv->stop(1).ok);
  EXPECT_TRUE(waitUntil([&] { return drv->read(&r).ok && !r.axes[1].moving; }));
}

TEST_F(TableOverProtocols, DriverRefusesBeyondDeviceLimits) {
  auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  auto drv = makeTableDriver(spec, log_.sink());
  const Status s = drv->setRate(0, 400 * kDegToRad);  // limit 300 deg/s: refused before I/O
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("exceeds the device limit"), std::string::npos) << s.message;
  EXPECT_FALSE(drv->moveTo(5, 0.0).ok);
}

// setProfile reaches the controller over every protocol: a rotation then runs at exactly the
// commanded rate and acceleration (the old drivers sent only the angle: the device maximum).
TEST_F(TableOverProtocols, ProfileReachesTheTableOverEveryProtocol) {
  const MotionLimits profile{12 * kDegToRad, 6 * kDegToRad};
  auto check = [&](VirtualWorld& world, TableDriver& drv) {
    ASSERT_TRUE(drv.connect().ok);
    ASSERT_TRUE(drv.interlock(InterlockCommand::kClose).ok);
    const int last = drv.spec().axisCount() - 1;
    ASSERT_TRUE(drv.setMode(last, AxisMode::kPosition).ok);
    Status s = drv.setProfile(last, profile);
    ASSERT_TRUE(s.ok) << s.message;
    s = drv.rotateBy(last, -kPi / 2);
    ASSERT_TRUE(s.ok) << s.message;
    settle(drv, last);
    const calib::Motion m = world.motionSnapshot();
    double rate = 0, accel = 0;
    for (const auto& p : m.axes[static_cast<size_t>(last)].phases()) {
      rate = std::max(rate, std::abs(p.rate0));
      accel = std::max(accel, std::abs(p.accel));
    }
    EXPECT_NEAR(rate, profile.rate, 1e-3 * profile.rate) << drv.spec().name();
    EXPECT_NEAR(accel, profile.accel, 1e-3 * profile.accel) << drv.spec().name();
    EXPECT_NEAR(m.axes[static_cast<size_t>(last)].at(m.duration).angle, -kPi / 2, 1e-6);
  };
  const auto chamber = testing::chamberSpec("generic-float-chamber.toml");
  {
    auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
    VirtualWorld world(spec, chamber, testing::kTestTimeScale);
    VirtualTableRegisters regs(world, spec, log_.sink());
    ModbusServer server(regs, faults_, log_.sink());
    ASSERT_TRUE(server.startTcp("127.0.0.1", 0).ok);
    spec.transport.port = server.port();
    check(world, *makeTableDriver(spec, log_.sink()));
  }
  {
    auto spec = testing::tableSpec("generic-3axis-rtu.toml");
    VirtualWorld world(spec, chamber, testing::kTestTimeScale);
    VirtualTableRegisters regs(world, spec, log_.sink());
    ModbusServer server(regs, faults_, log_.sink());
    ASSERT_TRUE(server.startRtu(spec.transport.unit_id).ok);
    spec.transport.device = server.ptyPath();
    check(world, *makeTableDriver(spec, log_.sink()));
  }
  {
    auto spec = testing::tableSpec("scpi-2axis-serial.toml");
    VirtualWorld world(spec, chamber, testing::kTestTimeScale);
    VirtualTableScpi server(world, spec, faults_, log_.sink());
    ASSERT_TRUE(server.start().ok);
    spec.transport.device = server.ptyPath();
    check(world, *makeTableDriver(spec, log_.sink()));
  }
}

// A device file without profile registers/commands: the driver refuses to set a profile
// (before any I/O) instead of letting the controller run at its own maximum; a profile
// beyond the spec's limits is refused too.
TEST_F(TableOverProtocols, ProfileRefusedWithoutRegistersOrBeyondLimits) {
  auto spec = testing::tableSpec("imubench-ref-2axis-tcp.toml");
  auto drv = makeTableDriver(spec, log_.sink());
  Status s = drv->setProfile(0, {400 * kDegToRad, 10 * kDegToRad});
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("exceeds the limits"), std::string::npos) << s.message;
  EXPECT_FALSE(drv->setProfile(0, {0.0, 10 * kDegToRad}).ok);
  for (auto& a : spec.registers.axes) a.rate_limit = a.accel_limit = RegisterField{};
  EXPECT_FALSE(spec.profileSettable());
  drv = makeTableDriver(spec, log_.sink());
  s = drv->setProfile(0, {10 * kDegToRad, 5 * kDegToRad});
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("gives no way to set the rate and acceleration"), std::string::npos)
      << s.message;
}

class ChamberOverProtocols : public ::testing::Test {
 protected:
  void exercise(VirtualWorld& world, ChamberDriver& drv, double tol) {
    ASSERT_TRUE(drv.connect().ok);
    Status s = drv.setRampRate(drv.spec().max_ramp);
    ASSERT_TRUE(s.ok) << s.message;
    ASSERT_TRUE(drv.setSetpoint(35.0).ok);
    ASSERT_TRUE(drv.run(true).ok);
    ChamberReading r;
    ASSERT_TRUE(drv.read(&r).ok);
    EXPECT_TRUE(r.running);
    EXPECT_NEAR(r.setpoint_c, 35.0, tol);
    EXPECT_NEAR(r.ramp_rate, drv.spec().max_ramp, 1e-4);
    EXPECT_TRUE(waitUntil([&] {
      return drv.read(&r).ok && std::abs(r.temperature_c - 35.0) < 0.15;
    })) << r.temperature_c;
    // The driver's reading is the world's temperature (to the register resolution).
    const double truth =
        world.withChamber([](VirtualChamber& c, double t) { return c.temperature(t); });
    EXPECT_NEAR(r.temperature_c, truth, 0.2);
    // A setpoint outside the device file's range is refused before any I/O.
    EXPECT_FALSE(drv.setSetpoint(300.0).ok);
    // Sensor break: the driver reports an alarm fault with its reason.
    world.withChamber([](VirtualChamber& c, double t) {
      c.setSensorBreak(t, true);
      return 0;
    });
    s = drv.read(&r);
    EXPECT_FALSE(s.ok);
    EXPECT_NE(s.message.find("sensor-break alarm"), std::string::npos) << s.message;
    EXPECT_EQ(drv.state(), DeviceState::kFault);
    EXPECT_TRUE(log_.contains("fault: sensor-break alarm")) << log_.all();
  }
  testing::EventLog log_;
  LinkFaults faults_;
};

TEST_F(ChamberOverProtocols, WatlowStyleOverModbusTcp) {
  auto spec = testing::chamberSpec("watlow-f4-style.toml");
  // 20 -> 35 degC at 5 degC/min with tau = 3 min is ~15 min: 3000x makes it well under 1 s.
  VirtualWorld world(testing::tableSpec("imubench-ref-2axis-tcp.toml"), spec, 3000.0);
  VirtualChamberRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startTcp("127.0.0.1", 0).ok);
  spec.transport.port = server.port();
  auto drv = makeChamberDriver(spec, log_.sink());
  exercise(world, *drv, 0.05);
}

TEST_F(ChamberOverProtocols, GenericFloatOverModbusRtu) {
  auto spec = testing::chamberSpec("generic-float-chamber.toml");
  VirtualWorld world(testing::tableSpec("imubench-ref-2axis-tcp.toml"), spec, 3000.0);
  VirtualChamberRegisters regs(world, spec, log_.sink());
  ModbusServer server(regs, faults_, log_.sink());
  ASSERT_TRUE(server.startRtu(spec.transport.unit_id).ok);
  spec.transport.kind = TransportKind::kModbusRtu;
  spec.transport.device = server.ptyPath();
  auto drv = makeChamberDriver(spec, log_.sink());
  exercise(world, *drv, 1e-5);
}

}  // namespace
}  // namespace imubench::drivers
