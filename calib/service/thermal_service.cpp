// The thermal part of the one calibration service (calib/service/calibration_service.h): the
// method, the table policy and the gate of `imubench thermal fit`.
#include <string>
#include <utility>

#include "calib/service/calibration_service.h"

namespace imubench::calib {
namespace {

// The note of the joint fit that says why `name` was held ("<name> is ..."), if any.
std::string heldNote(const std::vector<std::string>& notes, const std::string& name) {
  const std::string prefix = name + " ";
  for (const std::string& n : notes) {
    if (n.rfind(prefix, 0) == 0) return n.substr(prefix.size());
  }
  return "";
}

// Policy 2: what the method did with each table parameter of the kind.
std::vector<TableParamDecision> thermalTableDecisions(const ThermalCalibrationRequest& rq,
                                                      const ThermalRunsFitResult& fit) {
  std::vector<TableParamDecision> out;
  const TableKind kind = rq.runs.front().input.geometry.kind;
  for (const std::string& n : tableFlatNames(kind)) {
    TableParamDecision d{n, false, ""};
    const auto it = fit.table.uncertainty.find(n);
    if (rq.known_table_errors) {
      d.reason = "held at the given table errors (certification data)";
    } else if (rq.method == ThermalMethod::kPoints) {
      d.reason =
          "held at zero: the per-point method takes the table as nominal (the error leaks "
          "into the coefficients; the joint method estimates it)";
    } else if (it != fit.table.uncertainty.end() && it->second.observable && it->second.sigma) {
      d.estimated = true;
      d.reason = "estimated (constant over temperature)";
    } else {
      const std::string why = heldNote(fit.notes, n);
      d.reason = why.empty() ? "held at zero: the motion does not determine it" : why;
    }
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace

const char* thermalMethodName(ThermalMethod m) {
  return m == ThermalMethod::kJoint ? "joint" : "points";
}

bool ThermalServiceOptions::IsValid(std::string* why) const {
  return fit.IsValid(why) && joint.IsValid(why) && points.IsValid(why);
}

ThermalCalibrationOutcome calibrateThermal(const ThermalCalibrationRequest& rq,
                                           const ThermalServiceOptions& o) {
  ThermalCalibrationOutcome out;
  out.method = rq.method;
  std::string why;
  if (!o.IsValid(&why)) {
    out.status = FitStatus::Failed("options: " + why);
    return out;
  }
  if (rq.runs.empty()) {
    out.status = FitStatus::Failed("no recordings");
    return out;
  }
  if (rq.method == ThermalMethod::kJoint) {
    ThermalJointFitOptions jo = o.joint;
    jo.fit = o.fit;
    jo.estimate_table = !rq.known_table_errors.has_value();
    jo.direct.known_table_errors = rq.known_table_errors.value_or(TableErrors{});
    out.fit = fitThermalJoint(rq.runs, jo);
  } else {
    ThermalRunsFitOptions po = o.points;
    po.fit = o.fit;
    po.points.direct.known_table_errors = rq.known_table_errors.value_or(TableErrors{});
    out.fit = fitThermalRuns(rq.runs, po);
  }
  out.status = out.fit.status;
  if (out.status.HasResult()) out.table = thermalTableDecisions(rq, out.fit);
  return out;
}

}  // namespace imubench::calib
