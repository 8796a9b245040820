#include "daemon/run_calibration.h"

#include <cmath>

#include "calib/calibration_result.h"
#include "calib/service/calibration_service.h"
#include "calib/truth_comparison.h"
#include "imubench_build_id.h"
#include "io/sim_recording.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

using nlohmann::json;

// Every flat name the report marks unobservable.
std::vector<std::string> unobservableOf(const calib::CoefficientReport& r) {
  std::vector<std::string> out;
  for (const auto& [name, u] : r.uncertainty) {
    if (!u.observable) out.push_back(name);
  }
  return out;
}

json directReport(const calib::DirectCalibrationResult& d) {
  return {{"statics_used", d.statics_used},
          {"rotations_used", d.rotations_used},
          {"accel_residual_rms_mps2", d.accel_residual_rms},
          {"gyro_residual_rms_radps", d.gyro_residual_rms},
          {"goodness_of_fit", {{"accel", d.accel_normalised_rms}, {"gyro", d.gyro_normalised_rms}}},
          {"notes", d.notes}};
}

json indirectReport(const calib::CalibrationResult& r) {
  return {{"conditioning", calib::toJson(r.conditioning)},
          {"rms_normalised_residual", r.rms_normalised_residual},
          {"goodness_of_fit",
           {{"accel_holds", r.accel_normalised_rms},
            {"gyro_holds", r.gyro_normalised_rms},
            {"runs", r.run_normalised_rms}}},
          {"outer_iterations", r.outer_iterations},
          {"warnings", r.warnings}};
}

// The plan's method as the calibration service's request (calib/service/calibration_service.h).
calib::ServiceMethod serviceMethod(plans::CalibrationMethod method) {
  return method == plans::CalibrationMethod::kDirect ? calib::ServiceMethod::kDirect
                                                     : calib::ServiceMethod::kNavigation;
}

json outcomeReport(const char* method, const calib::CalibrationOutcome& c) {
  json report = {{"method", method}, {"why_method", c.why_method}};
  if (c.direct) report["direct"] = directReport(*c.direct);
  if (c.refined) report["indirect"] = indirectReport(*c.refined);
  if (!c.start.empty()) report["start"] = c.start;
  if (c.passes > 0) report["passes"] = c.passes;
  report["usable"] = c.status.IsSolutionUsable();
  if (c.status.HasResult() && !c.status.IsSolutionUsable()) {
    report["findings"] = c.status.reasons;
    report["largest_residuals"] = c.status.largest_residuals;
  }
  json table = json::array();
  for (const calib::TableParamDecision& d : c.table) {
    table.push_back({{"name", d.name}, {"estimated", d.estimated}, {"reason", d.reason}});
  }
  report["table"] = table;
  report["software"] = IMUBENCH_BUILD_ID;
  report["notes"] = c.notes;
  return report;
}

// One acceptance row: parameter `name` (under lim.parameter) against its limit.
json limitRow(const RunCalibration& c, const AcceptanceLimit& lim, const std::string& name) {
  const calib::DisplayUnit d = calib::displayUnit(name);
  json row = {{"parameter", name},
              {"limit", lim.limit / d.si_per_unit},
              {"unit", d.label},
              {"limit_text", lim.text}};
  const auto u = c.coefficients.uncertainty.find(name);
  const bool determined =
      c.status.ok && u != c.coefficients.uncertainty.end() && u->second.observable;
  if (!determined) {
    row["pass"] = false;
    row["why"] = "not determined by this calibration";
    return row;
  }
  double v = calib::flatValue(c.coefficients.values, name).value_or(0.0);
  if (name.find(".scale.") != std::string::npos) v -= 1.0;
  const bool ok = std::abs(v) <= lim.limit;
  row["value"] = v / d.si_per_unit;
  if (u->second.sigma) row["sigma"] = *u->second.sigma / d.si_per_unit;
  row["pass"] = ok;
  if (!ok) row["why"] = "outside the limit";
  return row;
}

}  // namespace

RunCalibration calibrateRun(plans::CalibrationMethod method, const io::Recording& rec,
                            const io::Recording* direct,
                            const std::optional<calib::TableErrors>& known_table_errors) {
  RunCalibration out;
  const char* name = plans::calibrationMethodName(method);
  if (method == plans::CalibrationMethod::kNone) {
    out.status = Status::Error("the plan names no calibration");
  } else if (method == plans::CalibrationMethod::kPipeline && direct == nullptr) {
    out.status = Status::Error("pipeline calibration: no direct-plan run");
    out.report = {{"method", name}};
  } else {
    const io::CalibrationView view(rec);
    std::optional<io::CalibrationView> direct_view;
    calib::CalibrationRequest rq;
    rq.recording = view.view();
    rq.method = serviceMethod(method);
    rq.known_table_errors = known_table_errors;
    if (method == plans::CalibrationMethod::kPipeline) {
      direct_view.emplace(*direct);
      rq.direct = direct_view->view();
    }
    const calib::CalibrationOutcome c = calib::calibrateRecording(rq);
    out.report = outcomeReport(name, c);
    out.fit = c.status;
    out.table_params = c.estimatedTableParams();
    out.baseline_method = calib::gyroReferenced(c.method) ? "indirect" : "direct";
    if (c.status.HasResult()) {
      out.status = Status::Ok();
      out.coefficients = c.coefficients;
      out.unobservable = unobservableOf(c.coefficients);
    } else {
      out.status = Status::Error(std::string(name) + " calibration: " + c.status.message);
    }
  }
  if (!out.status.ok) out.unobservable = calib::flatNames(calib::BenchTruth{});
  return out;
}

json estimateJson(const RunCalibration& c) {
  json params = json::object();
  if (c.status.ok) {
    for (const auto& [name, u] : c.coefficients.uncertainty) {
      if (!u.observable || !u.sigma) continue;
      const double v = calib::flatValue(c.coefficients.values, name).value_or(0.0);
      const bool scale = name.find(".scale.") != std::string::npos;
      const calib::DisplayUnit d = calib::displayUnit(name);
      params[name] = {{"value", (scale ? v - 1.0 : v) / d.si_per_unit},
                      {"sigma", *u.sigma / d.si_per_unit},
                      {"unit", d.label}};
    }
  }
  json out = {{"ok", c.status.ok},
              {"usable", c.status.ok && c.fit.IsSolutionUsable()},
              {"parameters", params},
              {"unobservable", c.unobservable}};
  if (!c.status.ok) out["reason"] = c.status.message;
  if (c.status.ok && !c.fit.IsSolutionUsable()) out["findings"] = c.fit.reasons;
  return out;
}

json acceptanceVerdict(const RunCalibration& c, const std::vector<AcceptanceLimit>& limits) {
  json rows = json::array();
  if (limits.empty()) return {{"pass", nullptr}, {"rows", rows}, {"why", "no acceptance limits"}};
  const bool usable = c.status.ok && c.fit.IsSolutionUsable();
  bool pass = c.status.ok;
  for (const AcceptanceLimit& lim : limits) {
    for (const std::string& name : calib::flatNames(calib::BenchTruth{})) {
      if (name != lim.parameter && name.rfind(lim.parameter + ".", 0) != 0) continue;
      json row = limitRow(c, lim, name);
      pass = pass && row["pass"].get<bool>();
      rows.push_back(std::move(row));
    }
  }
  json out = {{"pass", pass}, {"rows", rows}};
  out["usable"] = usable;
  if (!c.status.ok) {
    out["why"] = "calibration failed: " + c.status.message;
  } else if (!usable) {
    // No verdict on an unusable fit (a direct plan on a table with errors it takes as nominal,
    // a model that misses the physics, a plan that does not determine a coefficient): neither
    // PASS nor FAIL would be a measurement.
    out["pass"] = nullptr;
    const std::string values =
        std::string("the values ") + (pass ? "are within" : "exceed") + " the limits";
    if (c.fit.misfit) {
      out["why"] = "the fit is unusable (" + c.fit.message +
                   "): its values carry what the model left out and its sigmas understate the "
                   "error (" +
                   values +
                   "; `imubench explain` names the missing physics; a table with errors: give "
                   "them in the bench file's [table] errors)";
    } else {
      out["why"] = "the fit is unusable (" + c.fit.message +
                   "): the plan's motion does not determine every coefficient, or a value is "
                   "implausible (" +
                   values + "; the findings say which)";
    }
    out["findings"] = c.fit.reasons;
  }
  return out;
}

std::optional<double> runTemperature(const io::Recording& rec) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const io::ChamberSample& s : rec.chamber) {
    sum += s.temp_c;
    ++n;
  }
  if (n == 0) {
    for (const nav::ImuSample& s : rec.imu) {
      if (!std::isfinite(s.temp_c)) continue;
      sum += s.temp_c;
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  return sum / static_cast<double>(n);
}

}  // namespace imubench::daemon
