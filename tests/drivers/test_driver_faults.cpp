// Injected faults give a clear, logged error and a defined driver state, never a hang or a
// crash: delayed reply (within the timeout: ok; beyond: retries, then kFault), missing reply,
// dropped connection (reconnect per the device file's policy), interlock trip.
#include <gtest/gtest.h>

#include "drivers/table.h"
#include "nav/rotation.h"
#include "virtual_bench_fixture.h"

namespace imubench::drivers {
namespace {

using testing::waitUntil;

class ModbusFaults : public ::testing::Test {
 protected:
  ModbusFaults()
      : spec_(testing::tableSpec("imubench-ref-2axis-tcp.toml")),
        world_(spec_, testing::chamberSpec("generic-float-chamber.toml"), testing::kTestTimeScale),
        regs_(world_, spec_, log_.sink()),
        server_(regs_, faults_, log_.sink()) {
    EXPECT_TRUE(server_.startTcp("127.0.0.1", 0).ok);
    spec_.transport.port = server_.port();
    // Generous against a loaded machine: 500 ms per attempt, 2 retries.
    spec_.transport.retry.timeout_s = 0.5;
    spec_.transport.retry.retries = 2;
  }
  std::unique_ptr<TableDriver> connected() {
    auto d = makeTableDriver(spec_, log_.sink());
    EXPECT_TRUE(d->connect().ok);
    return d;
  }
  TableDeviceSpec spec_;
  testing::EventLog log_;
  LinkFaults faults_;
  VirtualWorld world_;
  VirtualTableRegisters regs_;
  ModbusServer server_;
};

TEST_F(ModbusFaults, DelayedReplyWithinTimeoutIsOk) {
  auto drv = connected();
  faults_.reply_delay_s = 0.05;
  TableReading r;
  const Status s = drv->read(&r);
  EXPECT_TRUE(s.ok) << s.message << "\n" << log_.all();
  EXPECT_EQ(drv->state(), DeviceState::kReady);
  EXPECT_TRUE(log_.contains("reply delayed by 50 ms"));
}

TEST_F(ModbusFaults, DelayedReplyBeyondTimeoutRetriesThenFaults) {
  auto drv = connected();
  faults_.reply_delay_s = 0.8;
  TableReading r;
  const Status s = drv->read(&r);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(drv->state(), DeviceState::kFault);
  // A read's first request is the host-watchdog heartbeat (the reference file declares one).
  EXPECT_NE(s.message.find("write heartbeat: fault after 3 attempts: no reply within 500 ms"),
            std::string::npos)
      << s.message;
  EXPECT_TRUE(log_.contains("attempt 1/3 failed: no reply within 500 ms")) << log_.all();
  EXPECT_TRUE(log_.contains("attempt 2/3 failed")) << log_.all();
  // The device answers again: the next call recovers.
  faults_.clear();
  const Status again = drv->read(&r);
  EXPECT_TRUE(again.ok) << again.message;
  EXPECT_EQ(drv->state(), DeviceState::kReady);
}

TEST_F(ModbusFaults, MissingReplyFaultsAfterRetries) {
  auto drv = connected();
  faults_.drop_replies = true;
  const Status s = drv->setMode(0, AxisMode::kPosition);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(drv->state(), DeviceState::kFault);
  EXPECT_NE(s.message.find("set mode (axis 0): fault after 3 attempts"), std::string::npos)
      << s.message;
  EXPECT_TRUE(log_.contains("request dropped without reply")) << log_.all();
}

TEST_F(ModbusFaults, DroppedConnectionReconnectsPerPolicy) {
  auto drv = connected();
  TableReading r;
  ASSERT_TRUE(drv->read(&r).ok);
  ASSERT_TRUE(waitUntil([&] { return server_.clientCount() == 1; }));
  server_.dropConnections();
  ASSERT_TRUE(waitUntil([&] { return server_.clientCount() == 0; }));
  const Status s = drv->read(&r);
  EXPECT_TRUE(s.ok) << s.message << "\n" << log_.all();
  EXPECT_EQ(drv->state(), DeviceState::kReady);
  EXPECT_TRUE(log_.contains("dropping 1 client connection")) << log_.all();
  EXPECT_TRUE(log_.contains("attempt 1/3 failed")) << log_.all();
  EXPECT_TRUE(log_.contains("succeeded on attempt 2")) << log_.all();
}

TEST_F(ModbusFaults, DroppedConnectionWithoutReconnectPolicyFaults) {
  spec_.transport.retry.reconnect = false;
  auto drv = connected();
  TableReading r;
  ASSERT_TRUE(drv->read(&r).ok);
  server_.dropConnections();
  ASSERT_TRUE(waitUntil([&] { return server_.clientCount() == 0; }));
  const Status s = drv->read(&r);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(drv->state(), DeviceState::kFault);
  EXPECT_NE(s.message.find("fault after"), std::string::npos) << s.message;
}

TEST_F(ModbusFaults, UnreachableDeviceIsOfflineWithReason) {
  spec_.transport.port = 1;  // nothing listens there
  auto drv = makeTableDriver(spec_, log_.sink());
  const Status s = drv->connect();
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(drv->state(), DeviceState::kOffline);
  EXPECT_NE(s.message.find("cannot connect"), std::string::npos) << s.message;
}

TEST_F(ModbusFaults, InterlockTripIsAFaultWithReason) {
  auto drv = connected();
  ASSERT_TRUE(drv->interlock(InterlockCommand::kClose).ok);
  ASSERT_TRUE(drv->setRate(0, 30 * kDegToRad).ok);
  TableReading r;
  ASSERT_TRUE(waitUntil([&] { return drv->read(&r).ok && r.axes[0].rate > 29 * kDegToRad; }));
  world_.withTable([](VirtualTable& t, double now) {
    t.trip(now, "door switch opened");
    return 0;
  });
  Status s = drv->read(&r);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("interlock tripped"), std::string::npos) << s.message;
  EXPECT_TRUE(r.interlock_tripped);
  EXPECT_EQ(drv->state(), DeviceState::kFault);
  EXPECT_TRUE(log_.contains("fault: interlock tripped")) << log_.all();
  // The table brakes to rest; motion commands are refused with the reason.
  EXPECT_TRUE(waitUntil([&] {
    drv->read(&r);
    return !r.axes[0].moving;
  }));
  s = drv->setRate(0, 10 * kDegToRad);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("motion refused: interlock tripped"), std::string::npos) << s.message;
  // Operator reset + close: ready again.
  ASSERT_TRUE(drv->interlock(InterlockCommand::kReset).ok);
  ASSERT_TRUE(drv->interlock(InterlockCommand::kClose).ok);
  s = drv->read(&r);
  EXPECT_TRUE(s.ok) << s.message;
  EXPECT_EQ(drv->state(), DeviceState::kReady);
  EXPECT_TRUE(r.interlock_closed);
}

class SerialFaults : public ::testing::Test {
 protected:
  SerialFaults()
      : spec_(testing::tableSpec("scpi-2axis-serial.toml")),
        world_(spec_, testing::chamberSpec("generic-float-chamber.toml"), testing::kTestTimeScale),
        server_(world_, spec_, faults_, log_.sink()) {
    EXPECT_TRUE(server_.start().ok);
    spec_.transport.device = server_.ptyPath();
    spec_.transport.retry.timeout_s = 0.5;
  }
  TableDeviceSpec spec_;
  testing::EventLog log_;
  LinkFaults faults_;
  VirtualWorld world_;
  VirtualTableScpi server_;
};

TEST_F(SerialFaults, DelayedAndMissingReplies) {
  auto drv = makeTableDriver(spec_, log_.sink());
  ASSERT_TRUE(drv->connect().ok);
  TableReading r;
  faults_.reply_delay_s = 0.05;
  EXPECT_TRUE(drv->read(&r).ok);
  faults_.reply_delay_s = 0.8;
  Status s = drv->read(&r);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(drv->state(), DeviceState::kFault);
  EXPECT_NE(s.message.find("(\"STAT?\"): fault after 3 attempts: no reply within the timeout"),
            std::string::npos)
      << s.message;
  faults_.clear();
  // Late replies of the timed-out attempts are discarded, not taken for later answers.
  EXPECT_TRUE(waitUntil([&] { return drv->read(&r).ok; }));
  EXPECT_EQ(drv->state(), DeviceState::kReady);
  faults_.drop_replies = true;
  s = drv->interlock(InterlockCommand::kClose);
  EXPECT_FALSE(s.ok);
  EXPECT_TRUE(log_.contains("fault injection: no reply to \"INTL:CLOSE\"")) << log_.all();
}

TEST_F(SerialFaults, DeviceRefusalIsReportedNotRetried) {
  auto drv = makeTableDriver(spec_, log_.sink());
  ASSERT_TRUE(drv->connect().ok);
  // Interlock open: the driver's own check refuses motion with the reason.
  const Status s = drv->rotateBy(0, kPi);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("interlock open"), std::string::npos) << s.message;
}

}  // namespace
}  // namespace imubench::drivers
