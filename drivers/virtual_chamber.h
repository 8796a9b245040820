// The virtual thermal chamber: the bench's thermal model (calib/model/thermal_lag.h, the one
// the plan expander predicts with): the setpoint is approached along the commanded ramp and the
// chamber air follows with a first-order lag (time constant from the device file), and the IMU
// follows the air with its own first-order lag (imu_tau_s: the IMU's mount, not the chamber's,
// so given by whoever runs the bench; 0: the IMU is at the air temperature). Pure model driven
// by explicit times; its history (the IMU's temperature) becomes calib::TemperatureKnot entries.
#pragma once

#include <cstdint>
#include <vector>

#include "calib/model/motion.h"
#include "calib/model/thermal_lag.h"
#include "drivers/device_file.h"

namespace imubench::drivers {

class VirtualChamber {
 public:
  VirtualChamber(const ChamberDeviceSpec& spec, double ambient_c = 20.0, double t0 = 0.0,
                 double imu_tau_s = 0.0);

  void setSetpoint(double t, double temp_c);
  void setRampRate(double t, double degc_per_s);  // 0: step
  void run(double t, bool on);
  // Fault injection: sensor break (alarm bit, temperature reads the sensor's rail).
  void setSensorBreak(double t, bool broken);

  double temperature(double t);     // the chamber air (what its sensor reads)
  double imuTemperature(double t);  // the IMU's own temperature (lagging the air)
  double setpoint() const { return setpoint_; }
  double rampRate() const { return ramp_; }
  bool running() const { return running_; }
  uint32_t alarmWord(double t);
  // (t, degC) knots, one every calib::model::kThermalKnotSpacing.
  const std::vector<calib::TemperatureKnot>& history(double t);
  const ChamberDeviceSpec& spec() const { return spec_; }

 private:
  void advance(double t);

  ChamberDeviceSpec spec_;
  double ambient_c_;
  double t_ = 0.0;  // time the state below belongs to
  calib::model::ThermalLag lag_;
  calib::model::ThermalState state_;  // ramp generator, air and IMU at t_
  double setpoint_;
  double ramp_ = 0.0;
  bool running_ = false;
  bool sensor_break_ = false;
  std::vector<calib::TemperatureKnot> history_;
};

}  // namespace imubench::drivers
