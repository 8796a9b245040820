// A simulated bench run as an imubench-csv/1 Recording (what `imubench simulate` and the
// virtual bench write): encoder angles rad -> deg, site rad -> deg, segments copied.
#pragma once

#include <string>

#include "calib/direct_calibration.h"
#include "calib/recording_view.h"
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

// A recording as the calibrators and the analysis read it (calib/recording_view.h): the table
// samples converted once and kept here, the rest viewed in the recording, which must outlive
// this. The one place a front end turns an io::Recording into calib's input.
class CalibrationView {
 public:
  explicit CalibrationView(const Recording& rec) : rec_(&rec), table_(tableSamples(rec)) {}
  calib::RecordingView view() const {
    return {geometryOf(*rec_), rec_->site(), rec_->imu, table_, rec_->segments};
  }
  const std::vector<calib::TableSample>& table() const { return table_; }
  // An owning copy, for a consumer that keeps the data beyond the recording (the thermal fits
  // keep and decimate their runs).
  calib::DirectCalibrationInput owned() const {
    return {geometryOf(*rec_), rec_->site(), rec_->imu, table_, rec_->segments};
  }

 private:
  const Recording* rec_;
  std::vector<calib::TableSample> table_;
};

}  // namespace imubench::io
