// The baseline of the model-discrepancy analysis (calib/explain/explain.h) when no coefficients are
// given: the recording calibrated by the one calibration service
// (calib/service/calibration_service.h) with the method its motion supports, without escalation:
// when the direct calibration determines every coefficient its result is the baseline even if
// unusable, since naming what it misses (the table errors among them) is the analysis' job.
//   direct    the direct calibration (calib/direct_calibration.h);
//   indirect  the navigation-based calibration (calib/indirect/indirect_calibration.h), which also
//             estimates the base tilt and nonorthogonality (table_params).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/explain/explain.h"
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
  int passes = 0;                         // indirect: passes of the pipeline
  std::vector<std::string> notes;         // why this method, what the other said
};

BaselineCalibration calibrateBaseline(const BaselineInput& input,
                                      const IncrementCheckOptions& checks = {});

// The baseline of a navigation recording with the direct plan's recording of the same device
// and table (`imubench explain NAV --direct DIRECT`): the production pipeline over both.
BaselineCalibration calibrateBaseline(const BaselineInput& navigation, const RecordingView& direct,
                                      const IncrementCheckOptions& checks = {});

// The analysis' input (calib/explain/explain.h): the recording and the baseline calibrated from it.
ExplainInput explainInput(const RecordingView& recording, const BaselineCalibration& base);

}  // namespace imubench::calib
