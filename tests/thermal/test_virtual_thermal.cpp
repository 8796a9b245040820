// Issue 16 item 7: the virtual bench follows the one thermal model. The virtual chamber's IMU
// temperature lags the air by the IMU's time constant exactly as calib/model/thermal_lag.h
// says, and the virtual IMU's sample producer (calib::ImuSimulator on the world's motion, what
// imubench-virtual-bench streams as CAN frames) with a thermal truth reports that temperature
// and applies the truth's coefficients at it: compensating its samples with the truth file
// gives back the ideal sensor's readings.
#include <gtest/gtest.h>

#include <cmath>

#include "calib/model/thermal_lag.h"
#include "calib/simulator.h"
#include "calib/thermal_model.h"
#include "drivers/virtual_chamber.h"
#include "tests/thermal/thermal_scenario.h"

namespace imubench::calib {
namespace {

constexpr double kAirTau = 120.0, kImuTau = 300.0;
constexpr double kRamp = 0.01;  // degC/s, 20 -> 60 degC
constexpr double kEnd = 4300.0;

// The chamber (air time constant kAirTau, IMU imu_tau behind it) commanded at t = 0 to ramp
// from 20 to 60 degC.
drivers::VirtualChamber rampingChamber(double imu_tau) {
  drivers::ChamberDeviceSpec spec;
  spec.time_constant_s = kAirTau;
  drivers::VirtualChamber c(spec, 20.0, 0.0, imu_tau);
  c.setRampRate(0.0, kRamp);
  c.setSetpoint(0.0, 60.0);
  c.run(0.0, true);
  return c;
}

// That chamber's history up to kEnd.
std::vector<TemperatureKnot> chamberHistory(double imu_tau) {
  return rampingChamber(imu_tau).history(kEnd);
}

TEST(VirtualThermal, ImuTemperatureLagsTheAirByTheImuTimeConstant) {
  drivers::VirtualChamber c = rampingChamber(kImuTau);
  model::ThermalState s = model::thermalAtRest(20.0);
  for (double t = 250.0; t <= kEnd; t += 250.0) {
    s = model::advanceThermal(s, 60.0, kRamp, {kAirTau, kImuTau}, 250.0);
    EXPECT_NEAR(c.temperature(t), s.air_c, 1e-9) << t;
    EXPECT_NEAR(c.imuTemperature(t), s.sensor_c, 1e-9) << t;
    EXPECT_NEAR(c.history(t).back().temp_c, s.sensor_c, 1e-9) << t;  // knots are the IMU's
  }
  // In the steady ramp the IMU trails the air by rate x tau_imu (3 degC), not by zero.
  drivers::VirtualChamber c2 = rampingChamber(kImuTau);
  EXPECT_NEAR(c2.temperature(3000.0) - c2.imuTemperature(3000.0), kRamp * kImuTau, 0.05);
}

// Static table at zero angles for the whole history.
Motion staticMotion(std::vector<TemperatureKnot> knots) {
  Motion m;
  m.axes.resize(2);
  for (auto& a : m.axes) a.append({0.0, 0.0, 0.0, 0.0});
  m.duration = kEnd;
  m.temperature = std::move(knots);
  return m;
}

nav::ImuSamples produce(const BenchWorld& world, const Motion& motion) {
  SimOptions o;
  o.imu_rate_hz = 10.0;
  std::string why;
  auto sim = ImuSimulator::Create(world, &motion, o, &why);
  EXPECT_NE(sim, nullptr) << why;
  nav::ImuSamples out;
  while (sim && sim->nextTime() < kEnd - 2.0) out.push_back(sim->next());
  return out;
}

TEST(VirtualThermal, ProducerCarriesTheLaggedTemperatureAndTheTruthsCoefficients) {
  const Motion motion = staticMotion(chamberHistory(kImuTau));
  BenchWorld world;
  world.site = testing::thermalSite();
  const nav::ImuSamples ideal = produce(world, motion);
  world.thermal = testing::cubicThermalTruth();
  const nav::ImuSamples imu = produce(world, motion);
  ASSERT_EQ(imu.size(), ideal.size());
  ASSERT_GT(imu.size(), 1000u);
  const model::ThermalLag lag{kAirTau, kImuTau};
  int checked = 0;
  double worst_a = 0.0, worst_g = 0.0, raw_a = 0.0;
  const ThermalApplyResult comp = applyThermal(*world.thermal, imu);
  ASSERT_TRUE(comp.status.ok) << comp.status.message;
  for (std::size_t k = 0; k < imu.size(); ++k) {
    const double t = imu[k].t;
    // The frame's temperature: the IMU's at the middle of its interval (knots 1 s apart).
    const model::ThermalState s =
        model::advanceThermal(model::thermalAtRest(20.0), 60.0, kRamp, lag, t - 0.05);
    EXPECT_NEAR(imu[k].temp_c, s.sensor_c, 2e-4) << t;
    // Steady ramp (transients below 1e-6 of the rate): the compensation's rate estimate and
    // the producer's agree, so the compensated sample must be the ideal one.
    if (t < 3000.0 || t > 3900.0) continue;
    worst_a = std::max(worst_a, (comp.compensated[k].dvel - ideal[k].dvel).norm() / 0.1);
    worst_g = std::max(worst_g, (comp.compensated[k].dtheta - ideal[k].dtheta).norm() / 0.1);
    raw_a = std::max(raw_a, (imu[k].dvel - ideal[k].dvel).norm() / 0.1);
    ++checked;
  }
  EXPECT_GT(checked, 8000);
  std::cout << "steady ramp: |compensated - ideal| accel " << worst_a << " m/s^2, gyro " << worst_g
            << " rad/s (uncompensated accel " << raw_a << " m/s^2)\n";
  EXPECT_LT(worst_a, 1e-7);  // the coefficients applied are the truth's at that temperature
  EXPECT_LT(worst_g, 1e-9);  // the stamp vs mid-interval temperature: ~1e-10
  EXPECT_GT(raw_a, 1e-3);    // and they do differ from the ideal sensor's
}

}  // namespace
}  // namespace imubench::calib
