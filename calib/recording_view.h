// One recording of the device on the table as the calibrators and the analysis read it: the
// table's geometry, the site and views of the data (the caller keeps the data). The inputs
// that read a recording (IndirectInput, ExplainInput, BaselineInput) are this view plus their
// own options, so one input's recording is another's by `a.recording() = b.recording()`.
#pragma once

#include <span>

#include "calib/model/motion.h"
#include "calib/simulator.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

struct RecordingView {
  TableGeometry geometry;               // kind and (two-axis) outer-axis heading
  nav::Site site;                       // gravity and Earth-rate projection
  std::span<const nav::ImuSample> imu;  // increments, t = END of each interval, increasing
  std::span<const TableSample> table;   // encoder angles (rad), t increasing
  std::span<const Segment> segments;    // static holds and rotate runs

  // The view itself, to set or copy the recording part of an input that extends it.
  RecordingView& recording() { return *this; }
  const RecordingView& recording() const { return *this; }
};

// The view of a recording that owns its data in members of the same names (e.g.
// DirectCalibrationInput).
template <class Owned>
RecordingView viewOf(const Owned& r) {
  return {r.geometry, r.site, r.imu, r.table, r.segments};
}

}  // namespace imubench::calib
