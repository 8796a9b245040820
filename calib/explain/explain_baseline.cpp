#include "calib/explain/explain_baseline.h"

#include "calib/service/calibration_service.h"

namespace imubench::calib {

namespace {

BaselineCalibration baselineOf(const CalibrationRequest& rq, const IncrementCheckOptions& checks) {
  ServiceOptions o;
  o.checks = checks;
  o.escalate_unusable = false;  // the analysis names what the plain model misses
  const CalibrationOutcome c = calibrateRecording(rq, o);
  BaselineCalibration out;
  out.status = c.status;
  out.method = gyroReferenced(c.method) ? "indirect" : "direct";
  out.coefficients = c.coefficients;
  out.table_params = c.estimatedTableParams();
  out.passes = c.passes;
  out.notes.push_back(c.why_method);
  for (const std::string& n : c.notes) out.notes.push_back(n);
  return out;
}

}  // namespace

BaselineCalibration calibrateBaseline(const BaselineInput& in,
                                      const IncrementCheckOptions& checks) {
  CalibrationRequest rq;
  rq.recording = in;
  return baselineOf(rq, checks);
}

BaselineCalibration calibrateBaseline(const BaselineInput& navigation, const RecordingView& direct,
                                      const IncrementCheckOptions& checks) {
  CalibrationRequest rq;
  rq.recording = navigation;
  rq.direct = direct;
  rq.method = ServiceMethod::kNavigation;
  return baselineOf(rq, checks);
}

ExplainInput explainInput(const RecordingView& recording, const BaselineCalibration& base) {
  ExplainInput in;
  in.recording() = recording;
  in.baseline = base.coefficients;
  in.baseline_method = base.method;
  in.baseline_table_params = base.table_params;
  return in;
}

}  // namespace imubench::calib
