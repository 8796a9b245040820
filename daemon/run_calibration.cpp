#include "daemon/run_calibration.h"

#include <cmath>

#include "calib/bench_calibration.h"
#include "calib/calibration_result.h"
#include "calib/direct_calibration.h"
#include "calib/indirect_calibration.h"
#include "calib/truth_comparison.h"
#include "io/sim_recording.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

using nlohmann::json;

// Unknowns of the direct calibration per sensor axis: scale, bias, two misalignments.
constexpr int kDirectUnknownsPerAxis = 4;

using io::geometryOf;
using io::tableSamples;

calib::DirectCalibrationInput directInput(const io::Recording& rec) {
  calib::DirectCalibrationInput in;
  in.geometry = geometryOf(rec);
  in.site = rec.site();
  in.imu = rec.imu;
  in.table = tableSamples(rec);
  in.segments = rec.segments;
  return in;
}

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
          {"notes", d.notes}};
}

json indirectReport(const calib::CalibrationResult& r) {
  return {{"conditioning", calib::toJson(r.conditioning)},
          {"rms_normalised_residual", r.rms_normalised_residual},
          {"outer_iterations", r.outer_iterations},
          {"warnings", r.warnings}};
}

RunCalibration fromDirect(const calib::DirectCalibrationResult& d) {
  RunCalibration out;
  out.report = {{"method", "direct"}, {"direct", directReport(d)}};
  if (!d.status.HasResult()) {
    out.status = Status::Error("direct calibration: " + d.status.message);
    return out;
  }
  // Four positions fit the four unknowns of each accelerometer axis exactly: no residual is
  // left, so the sigmas (from the residual scatter) would claim a precision nobody measured.
  if (d.statics_used <= kDirectUnknownsPerAxis) {
    out.status =
        Status::Error("direct calibration: " + std::to_string(d.statics_used) +
                      " static positions fit the " + std::to_string(kDirectUnknownsPerAxis) +
                      " unknowns per axis exactly: no redundancy yet, sigmas undefined");
    return out;
  }
  out.status = Status::Ok();
  out.coefficients = d.report;
  out.unobservable = unobservableOf(d.report);
  return out;
}

RunCalibration fromIndirect(const calib::CalibrationResult& r, const char* method) {
  RunCalibration out;
  out.report = {{"method", method}, {"indirect", indirectReport(r)}};
  if (!r.status.HasResult()) {
    out.status = Status::Error(std::string(method) + " calibration: " + r.status.message);
    return out;
  }
  out.status = Status::Ok();
  out.coefficients = r.coefficients;
  out.unobservable = unobservableOf(r.coefficients);
  return out;
}

// The navigation-based calibration of rec alone, started from the direct calibration of the
// same recording when that is usable (plausible scales), else from nominal values.
RunCalibration indirectAlone(const io::Recording& rec) {
  const calib::DirectCalibrationInput d_in = directInput(rec);
  const calib::DirectCalibrationResult d = calib::calibrateDirect(d_in);
  auto sane = [](const calib::TriadModel& t) {
    return ((t.scale.array() - 1.0).abs() < 0.01).all() && t.bias.allFinite();
  };
  calib::IndirectInput in;
  in.site = d_in.site;
  in.geometry = d_in.geometry;
  in.imu = rec.imu;
  in.table = d_in.table;
  in.segments = rec.segments;
  const bool started = d.status.HasResult() && sane(d.report.values.sensors.accel) &&
                       sane(d.report.values.sensors.gyro);
  if (started) in.start = d.report.values.sensors;
  RunCalibration out =
      fromIndirect(calib::calibrateIndirect(in, calib::IndirectOptions{}), "indirect");
  out.report["start"] = started ? "direct calibration of the same run" : "nominal";
  return out;
}

RunCalibration pipeline(const io::Recording& rec, const io::Recording* direct) {
  if (direct == nullptr) {
    RunCalibration out;
    out.status = Status::Error("pipeline calibration: no direct-plan run");
    out.report = {{"method", "pipeline"}};
    return out;
  }
  if (direct->table_kind != rec.table_kind) {
    RunCalibration out;
    out.status =
        Status::Error("pipeline calibration: the direct run was recorded on another table kind");
    out.report = {{"method", "pipeline"}};
    return out;
  }
  const std::vector<calib::TableSample> table = tableSamples(rec);
  calib::BenchCalibrationInput in;
  in.direct = directInput(*direct);
  in.navigation.push_back({rec.imu, table, rec.segments});
  const calib::BenchCalibrationResult r = calib::calibrateBench(in);
  RunCalibration out = fromIndirect(r.refined, "pipeline");
  if (!r.status.HasResult())
    out.status = Status::Error("pipeline calibration: " + r.status.message);
  out.report["direct"] = directReport(r.direct_final);
  out.report["passes"] = r.passes;
  return out;
}

}  // namespace

RunCalibration calibrateRun(plans::CalibrationMethod method, const io::Recording& rec,
                            const io::Recording* direct) {
  RunCalibration out;
  switch (method) {
    case plans::CalibrationMethod::kDirect:
      out = fromDirect(calib::calibrateDirect(directInput(rec)));
      break;
    case plans::CalibrationMethod::kIndirect:
      out = indirectAlone(rec);
      break;
    case plans::CalibrationMethod::kPipeline:
      out = pipeline(rec, direct);
      break;
    case plans::CalibrationMethod::kNone:
      out.status = Status::Error("the plan names no calibration");
      break;
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
  json out = {{"ok", c.status.ok}, {"parameters", params}, {"unobservable", c.unobservable}};
  if (!c.status.ok) out["reason"] = c.status.message;
  return out;
}

json acceptanceVerdict(const RunCalibration& c, const std::vector<AcceptanceLimit>& limits) {
  json rows = json::array();
  if (limits.empty()) return {{"pass", nullptr}, {"rows", rows}, {"why", "no acceptance limits"}};
  bool pass = c.status.ok;
  for (const AcceptanceLimit& lim : limits) {
    for (const std::string& name : calib::flatNames(calib::BenchTruth{})) {
      if (name != lim.parameter && name.rfind(lim.parameter + ".", 0) != 0) continue;
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
        pass = false;
        rows.push_back(row);
        continue;
      }
      double v = calib::flatValue(c.coefficients.values, name).value_or(0.0);
      if (name.find(".scale.") != std::string::npos) v -= 1.0;
      const bool ok = std::abs(v) <= lim.limit;
      row["value"] = v / d.si_per_unit;
      if (u->second.sigma) row["sigma"] = *u->second.sigma / d.si_per_unit;
      row["pass"] = ok;
      if (!ok) row["why"] = "outside the limit";
      pass = pass && ok;
      rows.push_back(row);
    }
  }
  json out = {{"pass", pass}, {"rows", rows}};
  if (!c.status.ok) out["why"] = "calibration failed: " + c.status.message;
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
