// The baseline of the model-discrepancy analysis (calib/explain.h) when no coefficients are
// given: the recording calibrated with the method its motion supports.
//   direct    when the direct calibration (calib/direct_calibration.h) determines every
//             coefficient (static positions with each axis up and down, rate runs about each
//             axis) and gives sane values;
//   indirect  otherwise, the navigation-based calibration (calib/indirect_calibration.h),
//             started from the direct result when that is sane (the seed's gyro-referenced
//             convention) or from nominal values (gyro misalignments estimated from the runs);
//             it also estimates the base tilt and nonorthogonality.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/explain.h"
#include "calib/fit_quality.h"
#include "calib/recording_view.h"
#include "calib/simulator.h"
#include "calib/static_detection.h"
#include "calib/table_model.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::calib {

using BaselineInput = RecordingView;

struct BaselineCalibration {
  // The chosen method's status; kFailed with why neither method could calibrate the recording.
  FitStatus status = FitStatus::Failed("not calibrated");
  std::string method;  // "direct" | "indirect"
  CoefficientReport coefficients;
  std::vector<std::string> table_params;  // table coefficients the method estimated (flat names)
  std::vector<std::string> notes;         // why this method, what the other said
};

BaselineCalibration calibrateBaseline(const BaselineInput& input,
                                      const IncrementCheckOptions& checks = {});

// The analysis' input (calib/explain.h): the recording and the baseline calibrated from it.
ExplainInput explainInput(const RecordingView& recording, const BaselineCalibration& base);

}  // namespace imubench::calib
