#include "calib/explain_baseline.h"

#include "calib/direct_calibration.h"
#include "calib/indirect_calibration.h"

namespace imubench::calib {
namespace {

// A triad a calibration may start from: scales within 1 % of one, finite biases.
bool sane(const TriadModel& t) {
  return ((t.scale.array() - 1.0).abs() < 0.01).all() && t.bias.allFinite();
}

bool fullyDetermined(const CoefficientReport& r) {
  for (const auto& [name, u] : r.uncertainty) {
    if ((name.rfind("accel.", 0) == 0 || name.rfind("gyro.", 0) == 0) && !u.observable) {
      return false;
    }
  }
  return true;
}

std::vector<std::string> tableNames(TableKind kind, const char* group) {
  BenchTruth t;
  t.table_kind = kind;
  std::vector<std::string> out;
  const std::string prefix = std::string("table.") + group + ".";
  for (const std::string& n : flatNames(t)) {
    if (n.rfind(prefix, 0) == 0) out.push_back(n);
  }
  return out;
}

}  // namespace

BaselineCalibration calibrateBaseline(const BaselineInput& in,
                                      const IncrementCheckOptions& checks) {
  BaselineCalibration out;
  DirectCalibrationInput din;
  din.geometry = in.geometry;
  din.site = in.site;
  din.imu.assign(in.imu.begin(), in.imu.end());
  din.table.assign(in.table.begin(), in.table.end());
  din.segments.assign(in.segments.begin(), in.segments.end());
  DirectCalibrationOptions dopt;
  dopt.checks = checks;
  const DirectCalibrationResult d = calibrateDirect(din, dopt);
  const bool direct_sane = d.status.HasResult() && sane(d.report.values.sensors.accel) &&
                           sane(d.report.values.sensors.gyro);
  if (direct_sane && fullyDetermined(d.report)) {
    out.status = d.status;
    out.method = "direct";
    out.coefficients = d.report;
    out.notes.push_back("direct calibration: " + std::to_string(d.statics_used) + " statics, " +
                        std::to_string(d.rotations_used) +
                        " rotations determine every coefficient");
    return out;
  }
  out.notes.push_back(d.status.HasResult()
                          ? "the direct calibration does not determine every coefficient on "
                            "this motion: navigation-based calibration instead"
                          : "direct calibration not possible (" + d.status.message +
                                "): navigation-based calibration instead");
  IndirectInput iin;
  iin.recording() = in;
  IndirectOptions iopt;
  iopt.checks = checks;
  if (direct_sane) {
    iin.start = d.report.values.sensors;
    iin.start_uncertainty = d.report.uncertainty;
  } else {
    iopt.gyro_reference = GyroReference::kEstimate;
  }
  const CalibrationResult r = calibrateIndirect(iin, iopt);
  if (!r.status.HasResult()) {
    out.status =
        FitStatus::Failed("neither calibration method fits this recording: direct: " +
                          (d.status.HasResult() ? std::string("incomplete") : d.status.message) +
                          "; navigation-based: " + r.status.message);
    return out;
  }
  out.status = r.status;
  out.method = "indirect";
  out.coefficients = r.coefficients;
  for (const char* g : {"base_tilt", "nonorthogonality"}) {
    for (const std::string& n : tableNames(in.geometry.kind, g)) out.table_params.push_back(n);
  }
  return out;
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
