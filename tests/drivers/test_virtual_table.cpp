// The virtual table's controller physics (pure, explicit times): acceleration-limited moves,
// shortest way in position mode, explicit direction for rotations, rate mode, interlock.
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/virtual_chamber.h"
#include "drivers/virtual_table.h"
#include "nav/rotation.h"
#include "virtual_bench_fixture.h"

namespace imubench::drivers {
namespace {

class VirtualTableTest : public ::testing::Test {
 protected:
  VirtualTableTest() : spec_(testing::tableSpec("imubench-ref-2axis-tcp.toml")), table_(spec_) {
    std::string why;
    table_.interlockClose(0.0, &why);
    EXPECT_TRUE(why.empty()) << why;
    EXPECT_TRUE(table_.setMode(0.0, 0, AxisMode::kPosition, &why)) << why;
  }
  // Largest |rate| and |accel| over the executed phases of axis i.
  void limitsUsed(int i, double t_end, double* max_rate, double* max_accel) {
    *max_rate = *max_accel = 0;
    for (const auto& p : table_.motion(t_end).axes[i].phases()) {
      *max_rate = std::max(*max_rate, std::abs(p.rate0));
      *max_accel = std::max(*max_accel, std::abs(p.accel));
    }
  }
  TableDeviceSpec spec_;
  VirtualTable table_;
};

TEST_F(VirtualTableTest, RestToRestMoveRespectsRateAndAccelLimits) {
  std::string why;
  ASSERT_TRUE(table_.moveTo(1.0, 0, 170 * kDegToRad, &why)) << why;
  // 170 deg at 100 deg/s^2 and 300 deg/s: triangular profile, peak sqrt(a d), time 2 sqrt(d/a).
  const double a = 100 * kDegToRad, d = 170 * kDegToRad;
  const double t_move = 2.0 * std::sqrt(d / a);
  const VirtualAxisStatus mid = table_.axis(1.0 + t_move / 2, 0);
  EXPECT_NEAR(mid.rate, std::sqrt(a * d), 1e-9);
  EXPECT_NEAR(mid.angle, d / 2, 1e-9);
  EXPECT_TRUE(mid.moving);
  const VirtualAxisStatus end = table_.axis(1.0 + t_move + 1e-6, 0);
  EXPECT_NEAR(end.angle, d, 1e-9);
  EXPECT_EQ(end.rate, 0.0);
  EXPECT_FALSE(end.moving);
  EXPECT_TRUE(end.in_position);
  double vr, ac;
  limitsUsed(0, 10.0, &vr, &ac);
  EXPECT_LE(vr, spec_.limits.max_rate + 1e-12);
  EXPECT_LE(ac, spec_.limits.max_accel + 1e-12);
}

// The commanded profile (the driver's setProfile) shapes moves and rotations; the device
// file's limits still cap it.
TEST_F(VirtualTableTest, CommandedProfileShapesMovesAndRotations) {
  std::string why;
  ASSERT_TRUE(table_.setRateLimit(0, 10 * kDegToRad, &why)) << why;
  ASSERT_TRUE(table_.setAccelLimit(0, 5 * kDegToRad, &why)) << why;
  ASSERT_TRUE(table_.rotateBy(0.0, 0, kPi, &why)) << why;
  // 180 deg at 10 deg/s, 5 deg/s^2: 2 s ramps (10 deg each), 16 s cruise: 20 s.
  EXPECT_NEAR(table_.axis(1.0, 0).rate, 5 * kDegToRad, 1e-12);
  EXPECT_NEAR(table_.axis(10.0, 0).rate, 10 * kDegToRad, 1e-12);
  EXPECT_TRUE(table_.axis(19.9, 0).moving);
  EXPECT_NEAR(table_.axis(20.0 + 1e-6, 0).angle, kPi, 1e-9);
  EXPECT_FALSE(table_.axis(20.0 + 1e-6, 0).moving);
  double vr, ac;
  limitsUsed(0, 30.0, &vr, &ac);
  EXPECT_NEAR(vr, 10 * kDegToRad, 1e-12);
  EXPECT_NEAR(ac, 5 * kDegToRad, 1e-12);
  // Above the device's 300 deg/s, 100 deg/s^2: the device's limits apply.
  ASSERT_TRUE(table_.setRateLimit(0, 1000 * kDegToRad, &why)) << why;
  ASSERT_TRUE(table_.setAccelLimit(0, 1000 * kDegToRad, &why)) << why;
  ASSERT_TRUE(table_.rotateBy(30.0, 0, 8 * kPi, &why)) << why;
  limitsUsed(0, 100.0, &vr, &ac);
  EXPECT_NEAR(vr, spec_.limits.max_rate, 1e-12);
  EXPECT_NEAR(ac, spec_.limits.max_accel, 1e-12);
  EXPECT_FALSE(table_.setRateLimit(0, 0.0, &why));
  EXPECT_FALSE(table_.setAccelLimit(0, -1.0, &why));
  EXPECT_FALSE(table_.setRateLimit(7, 1.0, &why));
}

TEST_F(VirtualTableTest, LongMoveCruisesAtMaxRate) {
  std::string why;
  // Four turns: long enough (1440 deg > v^2/a = 900 deg) to reach the rate limit.
  ASSERT_TRUE(table_.rotateBy(0.0, 0, 8 * kPi, &why)) << why;
  const double v = spec_.limits.max_rate, a = spec_.limits.max_accel;
  const double t_total = 8 * kPi / v + v / a;  // trapezoid
  EXPECT_NEAR(table_.axis(t_total / 2, 0).rate, v, 1e-9);
  EXPECT_NEAR(table_.axis(t_total + 1e-6, 0).angle, 8 * kPi, 1e-9);
  EXPECT_NEAR(table_.axis(t_total + 1e-6, 0).reported_angle, 0.0, 1e-9);
}

TEST_F(VirtualTableTest, PositionModeTakesTheShortestWay) {
  std::string why;
  ASSERT_TRUE(table_.moveTo(0.0, 0, 270 * kDegToRad, &why)) << why;
  // 270 deg from 0 is -90 deg the short way: the axis turns negative.
  EXPECT_LT(table_.axis(0.5, 0).rate, 0.0);
  const VirtualAxisStatus end = table_.axis(30.0, 0);
  EXPECT_NEAR(end.angle, -90 * kDegToRad, 1e-9);
  EXPECT_NEAR(end.reported_angle, -90 * kDegToRad, 1e-9);
}

TEST_F(VirtualTableTest, ReversalNeedsExplicitDirection) {
  std::string why;
  ASSERT_TRUE(table_.rotateBy(0.0, 0, -kPi, &why)) << why;
  EXPECT_LT(table_.axis(0.5, 0).rate, 0.0);
  EXPECT_NEAR(table_.axis(30.0, 0).angle, -kPi, 1e-9);
  ASSERT_TRUE(table_.rotateBy(30.0, 0, kPi, &why)) << why;
  EXPECT_GT(table_.axis(30.5, 0).rate, 0.0);
  EXPECT_NEAR(table_.axis(60.0, 0).angle, 0.0, 1e-9);
}

TEST_F(VirtualTableTest, NewCommandReplacesTheRestOfAMove) {
  std::string why;
  ASSERT_TRUE(table_.rotateBy(0.0, 0, 2 * kPi, &why)) << why;
  const VirtualAxisStatus s = table_.axis(1.0, 0);
  ASSERT_GT(s.rate, 0.0);
  ASSERT_TRUE(table_.moveTo(1.0, 0, 0.0, &why)) << why;  // turn back while moving forward
  // The rate is continuous at the switch (no jump) and the axis ends at 0.
  EXPECT_NEAR(table_.axis(1.0, 0).rate, s.rate, 1e-12);
  EXPECT_NEAR(table_.axis(60.0, 0).angle, 0.0, 1e-9);
  EXPECT_FALSE(table_.axis(60.0, 0).moving);
  double vr, ac;
  limitsUsed(0, 60.0, &vr, &ac);
  EXPECT_LE(ac, spec_.limits.max_accel + 1e-12);
  // The executed motion is a valid calib::Motion: phases sorted, angle continuous.
  const auto& ph = table_.motion(60.0).axes[0].phases();
  for (size_t k = 1; k < ph.size(); ++k) {
    const auto& p = ph[k - 1];
    const double dt = ph[k].t0 - p.t0;
    ASSERT_GE(dt, 0.0);
    EXPECT_NEAR(p.angle0 + p.rate0 * dt + 0.5 * p.accel * dt * dt, ph[k].angle0, 1e-9);
    EXPECT_NEAR(p.rate0 + p.accel * dt, ph[k].rate0, 1e-9);
  }
}

TEST_F(VirtualTableTest, RateModeAndInterlockTrip) {
  std::string why;
  ASSERT_TRUE(table_.setMode(0.0, 1, AxisMode::kRate, &why)) << why;
  ASSERT_TRUE(table_.setRate(0.0, 1, 50 * kDegToRad, &why)) << why;
  EXPECT_NEAR(table_.axis(10.0, 1).rate, 50 * kDegToRad, 1e-12);
  table_.trip(10.0, "door switch");
  // Braking at the acceleration limit: 0.5 s from 50 deg/s at 100 deg/s^2.
  EXPECT_GT(table_.axis(10.25, 1).rate, 0.0);
  EXPECT_EQ(table_.axis(10.5 + 1e-9, 1).rate, 0.0);
  EXPECT_FALSE(table_.setRate(11.0, 1, 10 * kDegToRad, &why));
  EXPECT_NE(why.find("door switch"), std::string::npos) << why;
  const uint32_t st = table_.statusWord(11.0);
  EXPECT_TRUE(st & (1u << spec_.bits.interlock_tripped));
  EXPECT_FALSE(st & (1u << spec_.bits.interlock_closed));
  why.clear();
  table_.interlockClose(11.0, &why);
  EXPECT_FALSE(why.empty());  // a tripped interlock needs a reset first
  table_.interlockReset(12.0);
  why.clear();
  table_.interlockClose(12.0, &why);
  EXPECT_TRUE(why.empty()) << why;
  EXPECT_TRUE(table_.setRate(12.0, 1, 10 * kDegToRad, &why)) << why;
}

// The host watchdog (reference file: 0.5 s). Heartbeats every 0.1 s up to t = 5 s while the
// outer axis runs 20 turns at 300 deg/s (reached at t = 3 s): from t = 5.5 s exactly it brakes
// at the device's 100 deg/s^2 to rest 3 s later, and the interlock is open from then on.
// Time injected.
TEST_F(VirtualTableTest, WatchdogBrakesAndOpensTheInterlockWhenTheHeartbeatStops) {
  std::string why;
  ASSERT_NEAR(table_.watchdogTimeout(), 0.5, 1e-12);
  ASSERT_TRUE(table_.rotateBy(0.0, 0, 40 * kPi, &why)) << why;
  for (int k = 0; k <= 50; ++k) table_.heartbeat(0.1 * k, static_cast<uint32_t>(k));
  EXPECT_TRUE(table_.watchdogArmed());
  EXPECT_EQ(table_.heartbeats(), 51u);
  const double rate = 300 * kDegToRad, accel = 100 * kDegToRad;
  const double t_out = 0.1 * 50 + 0.5;
  // Still running at full rate just before the timeout runs out, read after it (lazily).
  EXPECT_NEAR(table_.axis(t_out - 1e-9, 0).rate, rate, 1e-6);
  EXPECT_TRUE(table_.interlockClosed());
  EXPECT_NEAR(table_.axis(t_out + 1.0, 0).rate, rate - accel * 1.0, 1e-9);
  EXPECT_FALSE(table_.interlockClosed());
  EXPECT_EQ(table_.watchdogExpiries(), 1);
  EXPECT_FALSE(table_.watchdogArmed());
  const double t_rest = t_out + rate / accel;
  EXPECT_TRUE(table_.axis(t_rest - 0.01, 0).moving);
  const VirtualAxisStatus rest = table_.axis(t_rest + 1e-6, 0);
  EXPECT_EQ(rest.rate, 0.0);
  EXPECT_FALSE(rest.moving);
  const uint32_t st = table_.statusWord(t_rest + 1.0);
  EXPECT_FALSE(st & (1u << spec_.bits.interlock_closed));
  EXPECT_FALSE(st & (1u << spec_.bits.interlock_tripped));  // no trip, no estop: re-arm works
  EXPECT_FALSE(st & (1u << spec_.bits.estop));
  EXPECT_EQ(table_.watchdogExpiries(), 1);  // disarmed: once
}

// A command that arrives after the timeout ran out finds the interlock open, though nothing
// read the table in between.
TEST_F(VirtualTableTest, WatchdogExpiredBeforeACommandRefusesIt) {
  std::string why;
  table_.heartbeat(1.0, 1);
  EXPECT_FALSE(table_.rotateBy(1.6, 0, kPi, &why));
  EXPECT_NE(why.find("interlock open"), std::string::npos) << why;
  EXPECT_EQ(table_.watchdogExpiries(), 1);
}

// Writing the same value again is no sign of life; a table never given a heartbeat never
// arms; re-armed (interlock closed) and fed again, it moves again.
TEST_F(VirtualTableTest, WatchdogNeedsAChangingHeartbeatAndRearms) {
  std::string why;
  EXPECT_TRUE(table_.rotateBy(0.0, 0, kPi, &why)) << why;
  EXPECT_TRUE(table_.interlockClosed());
  table_.statusWord(100.0);
  EXPECT_TRUE(table_.interlockClosed()) << "never armed: never fires";
  table_.heartbeat(100.0, 7);
  table_.heartbeat(100.3, 7);
  table_.heartbeat(100.6, 7);  // past 100.5: the first 7 was the last sign of life
  EXPECT_FALSE(table_.interlockClosed());
  EXPECT_EQ(table_.watchdogExpiries(), 1);
  table_.interlockClose(101.0, &why);
  ASSERT_TRUE(why.empty()) << why;
  table_.heartbeat(101.0, 8);
  table_.heartbeat(101.4, 9);
  EXPECT_TRUE(table_.rotateBy(101.8, 0, kPi, &why)) << why;
  EXPECT_TRUE(table_.axis(101.85, 0).moving);
  EXPECT_TRUE(table_.interlockClosed());
  EXPECT_EQ(table_.watchdogExpiries(), 1);
}

// The world times the heartbeats on the wall clock: at time scale 20 the timeout is 10 s of
// simulated time.
TEST(VirtualWorldWatchdog, TimeoutFollowsTheTimeScale) {
  VirtualWorld world(testing::tableSpec("imubench-ref-2axis-tcp.toml"),
                     testing::chamberSpec("generic-float-chamber.toml"), 20.0);
  EXPECT_NEAR(world.withTable([](VirtualTable& t, double) { return t.watchdogTimeout(); }), 10.0,
              1e-12);
}

TEST(VirtualChamber, FirstOrderResponseToAStep) {
  auto spec = testing::chamberSpec("generic-float-chamber.toml");  // tau = 90 s
  VirtualChamber ch(spec, 20.0, 0.0);
  ch.setSetpoint(0.0, 60.0);
  ch.run(0.0, true);
  // Step (no ramp): T(t) = 60 - 40 exp(-t/tau).
  EXPECT_NEAR(ch.temperature(90.0), 60.0 - 40.0 * std::exp(-1.0), 1e-6);
  EXPECT_NEAR(ch.temperature(900.0), 60.0 - 40.0 * std::exp(-10.0), 1e-6);
  EXPECT_EQ(ch.alarmWord(900.0), 0u);
  EXPECT_GT(ch.history(900.0).size(), 100u);
}

TEST(VirtualChamber, RampLimitsTheApproach) {
  auto spec = testing::chamberSpec("generic-float-chamber.toml");
  VirtualChamber ch(spec, 20.0, 0.0);
  ch.setRampRate(0.0, 1.0 / 60.0);  // 1 degC/min
  ch.setSetpoint(0.0, 30.0);
  ch.run(0.0, true);
  // After 5 min the ramp generator is at 25 degC; the air lags it by about rate x tau.
  const double t = 300.0;
  const double lag = (1.0 / 60.0) * 90.0 * (1.0 - std::exp(-t / 90.0));
  EXPECT_NEAR(ch.temperature(t), 25.0 - lag, 0.05);
}

}  // namespace
}  // namespace imubench::drivers
