// What the simulated IMU saw during each rotation of a plan (the `imubench run` table):
// pure functions over the simulation, so they are tested without the CLI.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/model/motion.h"
#include "nav/imu_sample.h"

namespace imubench::tools {

struct RotationSummary {
  std::string label;
  int axis = -1;           // table axis index (calib/model/motion.h order)
  double angle_rad = 0.0;  // commanded signed table rotation
  double duration_s = 0.0;
  Vec3 gyro_angle_rad = Vec3::Zero();  // sum of dtheta over the rotation, per IMU axis
  // Mean specific force dv/dt over the nearest static segment before / after, m/s^2.
  std::optional<Vec3> f_before;
  std::optional<Vec3> f_after;
};

// One entry per kRotate segment, in time order.
std::vector<RotationSummary> summarizeRotations(const std::vector<calib::Segment>& segments,
                                                const nav::ImuSamples& imu);

// Mean dv/dt of the samples whose interval lies in [t0, t1]; nullopt when none.
std::optional<Vec3> meanSpecificForce(const nav::ImuSamples& imu, double t0, double t1);

// The compact table: one header, one line per rotation.
std::string formatRotationTable(const std::vector<RotationSummary>& runs,
                                const std::vector<std::string>& axis_names);

}  // namespace imubench::tools
