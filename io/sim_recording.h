// A simulated bench run as an imubench-csv/1 Recording (what `imubench simulate` and the
// virtual bench write): encoder angles rad -> deg, site rad -> deg, segments copied.
#pragma once

#include <string>

#include "calib/simulator.h"
#include "io/recording.h"

namespace imubench::io {

struct RecordingIdentity {
  std::string imu_serial = "SIM-0001";        // what a real IMU reports; simulated runs get a tag
  double imu_rate_hz = 200.0;                 // the rate the simulation ran at
  double outer_axis_heading_rad = kPi / 2.0;  // two-axis only (written to meta.json)
};

Recording recordingFromSimulation(const calib::Simulation& sim, const nav::Site& site,
                                  const RecordingIdentity& id);

// The calibrators' view of a recording's table: samples as calib::TableSample (encoder angles
// in rad as TableAngles) and the table geometry (kind, outer-axis heading from meta.json).
std::vector<calib::TableSample> tableSamples(const Recording& rec);
calib::TableGeometry geometryOf(const Recording& rec);

}  // namespace imubench::io
