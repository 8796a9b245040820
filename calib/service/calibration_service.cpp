#include "calib/service/calibration_service.h"

#include <cmath>
#include <utility>

#include "calib/option_check.h"
#include "calib/segment_check.h"

namespace imubench::calib {
namespace {

// A triad a calibration may start from: scales close to one, finite biases.
bool plausibleStart(const TriadModel& t, double max_scale_deviation) {
  return ((t.scale.array() - 1.0).abs() < max_scale_deviation).all() && t.bias.allFinite();
}

bool plausibleStart(const DirectCalibrationResult& d, const ServiceOptions& o) {
  return d.status.HasResult() &&
         plausibleStart(d.report.values.sensors.accel, o.max_start_scale_deviation) &&
         plausibleStart(d.report.values.sensors.gyro, o.max_start_scale_deviation);
}

// Every sensor coefficient determined (none flagged unobservable).
bool fullyDetermined(const CoefficientReport& r) {
  for (const auto& [name, u] : r.uncertainty) {
    if ((name.rfind("accel.", 0) == 0 || name.rfind("gyro.", 0) == 0) && !u.observable) {
      return false;
    }
  }
  return true;
}

bool inGroup(const std::string& name, const char* group) {
  return name.rfind(std::string("table.") + group + ".", 0) == 0;
}

// Policy 3: what each method did with each table parameter of the kind.
std::vector<TableParamDecision> tableDecisions(TableKind kind, ServiceMethod method,
                                               const CalibrationRequest& rq,
                                               const IndirectOptions& io) {
  std::vector<TableParamDecision> out;
  const bool known = rq.known_table_errors.has_value();
  for (const std::string& n : tableFlatNames(kind)) {
    TableParamDecision d{n, false, ""};
    if (known) {
      d.reason = method == ServiceMethod::kNavigation
                     ? "held at the given table errors (certification data) as the "
                       "navigation-based frame takes them"
                     : "held at the given table errors (certification data)";
      if (method == ServiceMethod::kNavigation && inGroup(n, "base_tilt") &&
          io.estimate_base_tilt) {
        d.estimated = true;
        d.reason = "estimated, started at the given value";
      }
    } else if (method == ServiceMethod::kDirect) {
      d.reason =
          "held at zero: the direct calibration takes the table as nominal (the error "
          "leaks into the coefficients; `imubench explain` names it)";
    } else if ((inGroup(n, "base_tilt") && io.estimate_base_tilt) ||
               (inGroup(n, "nonorthogonality") && io.estimate_nonorthogonality)) {
      d.estimated = true;
    } else if (inGroup(n, "mounting") || inGroup(n, "encoder_zero")) {
      d.reason =
          "not separable by this method: absorbed into the gyro-referenced frame "
          "(mounting, inner encoder zero), the base tilt (outer zero of a two-axis "
          "table) or the middle nonorthogonality (middle zero of a three-axis table)";
    } else {
      d.reason = "held at zero by the options";
    }
    if (d.estimated && d.reason.empty()) d.reason = "estimated";
    out.push_back(std::move(d));
  }
  return out;
}

// What the segments of a recording hold, counted as the calibrators see them (a hold split
// into settle + hold is one hold).
void countMotion(const RecordingView& v, const ServiceOptions& o, CalibrationOutcome* out) {
  const SegmentCheckResult c =
      checkSegments(v.geometry.kind, v.table, v.segments, o.direct.segment_check);
  for (const Segment& s : c.segments) {
    if (!s.recording) continue;
    out->holds += s.kind == SegmentKind::kStatic ? 1 : 0;
    out->runs += s.kind == SegmentKind::kRotate ? 1 : 0;
  }
}

// Known table errors as the navigation-based method's frame holds them
// (calib/indirect/indirect_calibration.h): mounting and the inner encoder zero are absorbed by the
// gyro-referenced frame, the outer zero of a two-axis table joins the tilt about the outer
// axis, the middle zero of a three-axis table joins middle_x. Its direct start must take the
// same, or the two work in different frames.
TableErrors navigationFrame(const TableErrors& known, const TableGeometry& geometry) {
  BenchTruth t;
  t.table = known;
  t.table_kind = geometry.kind;
  const GyroReferencedTruth g = toGyroReferenced(t, geometry);
  TableErrors out;
  out.base_tilt = g.base_tilt;
  out.nonorthogonality = g.nonorthogonality;
  return out;
}

// The direct calibration's options; navigation: as the start of the navigation-based method.
DirectCalibrationOptions directOptions(const CalibrationRequest& rq, const ServiceOptions& o,
                                       bool navigation = false) {
  DirectCalibrationOptions d = o.direct;
  d.checks = o.checks;
  if (rq.known_table_errors) {
    d.known_table_errors = navigation
                               ? navigationFrame(*rq.known_table_errors, rq.recording.geometry)
                               : *rq.known_table_errors;
  }
  return d;
}

IndirectOptions indirectOptions(const CalibrationRequest& rq, const ServiceOptions& o) {
  IndirectOptions io = o.indirect;
  io.checks = o.checks;
  io.sigma_check = o.sigma_check;
  if (rq.known_table_errors) io.estimate_nonorthogonality = false;
  return io;
}

const RecordingView& directView(const CalibrationRequest& rq) {
  return rq.direct ? *rq.direct : rq.recording;
}

// The direct calibration as the outcome: the redundancy check on top of the calibrator's own
// gate.
CalibrationOutcome fromDirect(const DirectCalibrationResult& d, const ServiceOptions& o) {
  CalibrationOutcome out;
  out.method = ServiceMethod::kDirect;
  out.direct = d;
  out.status = d.status;
  if (!d.status.HasResult()) {
    out.status = FitStatus::Failed("direct calibration: " + d.status.message);
    return out;
  }
  if (d.statics_used <= o.direct_unknowns_per_axis) {
    out.status = FitStatus::Failed("direct calibration: " + std::to_string(d.statics_used) +
                                   " static positions fit the " +
                                   std::to_string(o.direct_unknowns_per_axis) +
                                   " unknowns per axis exactly: no redundancy, sigmas undefined");
    return out;
  }
  out.coefficients = d.report;
  return out;
}

// The refinement from given start values (a coefficient file), no direct step.
CalibrationOutcome navigationFromStart(const CalibrationRequest& rq, const ServiceOptions& o) {
  CalibrationOutcome out;
  out.method = ServiceMethod::kNavigation;
  out.start = "given";
  IndirectInput in;
  in.recording() = rq.recording;
  if (rq.direct) in.extra_legs.push_back({rq.direct->imu, rq.direct->table, rq.direct->segments});
  in.start = rq.start->values.sensors;
  in.start_uncertainty = rq.start->uncertainty;
  in.start_base_tilt = rq.start->values.table.base_tilt;
  if (rq.known_table_errors) {
    const TableErrors known = navigationFrame(*rq.known_table_errors, rq.recording.geometry);
    in.start_base_tilt = known.base_tilt;
    in.start_nonorthogonality = known.nonorthogonality;
  }
  out.refined = calibrateIndirect(in, indirectOptions(rq, o));
  out.passes = 1;
  return out;
}

// The refinement from nominal values when no direct result can start it: the gyro
// misalignments come from the runs.
CalibrationOutcome navigationFromNominal(const CalibrationRequest& rq, const ServiceOptions& o) {
  CalibrationOutcome out;
  out.method = ServiceMethod::kNavigation;
  out.start = "nominal";
  IndirectInput in;
  in.recording() = rq.recording;
  if (rq.direct) in.extra_legs.push_back({rq.direct->imu, rq.direct->table, rq.direct->segments});
  if (rq.known_table_errors) {
    const TableErrors known = navigationFrame(*rq.known_table_errors, rq.recording.geometry);
    in.start_base_tilt = known.base_tilt;
    in.start_nonorthogonality = known.nonorthogonality;
  }
  IndirectOptions io = indirectOptions(rq, o);
  io.gyro_reference = GyroReference::kEstimate;
  out.refined = calibrateIndirect(in, io);
  out.passes = 1;
  return out;
}

// The production pipeline from the first direct calibration d (calib/indirect/bench_calibration.h).
CalibrationOutcome navigationFromDirect(const CalibrationRequest& rq, const ServiceOptions& o,
                                        const DirectCalibrationResult& d) {
  CalibrationOutcome out;
  out.method = ServiceMethod::kNavigation;
  out.start = "direct calibration";
  BenchCalibrationInput in;
  in.direct = directView(rq);
  if (rq.direct) {
    in.navigation.push_back({rq.recording.imu, rq.recording.table, rq.recording.segments});
  }
  BenchCalibrationOptions bo;
  bo.direct = directOptions(rq, o, true);
  bo.indirect = indirectOptions(rq, o);
  bo.nonorthogonality_significance_sigma = o.nonorthogonality_significance_sigma;
  bo.max_passes = o.max_passes;
  bo.convergence_sigma = o.convergence_sigma;
  BenchCalibrationResult r = calibrateBenchFrom(in, d, bo);
  out.direct_first = std::move(r.direct);
  out.direct = std::move(r.direct_final);
  out.refined = std::move(r.refined);
  out.passes = r.passes;
  out.status = r.status;
  if (out.passes >= 2) {
    out.notes.push_back(
        "table axes nonorthogonal: direct calibration repeated with the estimated "
        "nonorthogonality, refinement repeated from it (" +
        std::to_string(out.passes) + " passes)");
  }
  return out;
}

// Policy 2: the navigation-based calibration from the best start; `first` is the direct
// calibration of the direct recording when the caller already has it.
CalibrationOutcome navigation(const CalibrationRequest& rq, const ServiceOptions& o,
                              std::optional<DirectCalibrationResult> first) {
  CalibrationOutcome out;
  if (rq.start) {
    out = navigationFromStart(rq, o);
  } else {
    if (!first) first = calibrateDirect(directView(rq), directOptions(rq, o, true));
    if (plausibleStart(*first, o)) {
      out = navigationFromDirect(rq, o, *first);
    } else {
      out = navigationFromNominal(rq, o);
      out.direct_first = first;
      out.notes.push_back(
          first->status.HasResult()
              ? "the direct calibration gives implausible values on this motion: the "
                "navigation-based calibration starts from nominal values"
              : "no direct calibration to start from (" + first->status.message +
                    "): the navigation-based calibration starts from nominal values");
    }
  }
  if (out.start != "direct calibration") {
    const FitStatus& s = out.refined->status;
    out.status =
        s.HasResult() ? s : FitStatus::Failed("navigation-based calibration: " + s.message);
  }
  if (out.status.HasResult()) out.coefficients = out.refined->coefficients;
  return out;
}

// Policy 1 for kAuto on a recording with runs: the direct calibration when it determines
// every coefficient plausibly (and is usable, or escalation is off), else navigation.
CalibrationOutcome automatic(const CalibrationRequest& rq, const ServiceOptions& o,
                             const std::string& counts) {
  const DirectCalibrationResult d = calibrateDirect(directView(rq), directOptions(rq, o));
  const bool direct_complete = plausibleStart(d, o) && fullyDetermined(d.report);
  if (direct_complete && (d.status.IsSolutionUsable() || !o.escalate_unusable)) {
    CalibrationOutcome out = fromDirect(d, o);
    out.why_method =
        "direct: the direct calibration determines every coefficient from the " + counts;
    return out;
  }
  // With known table errors the navigation-based start takes them in its own frame.
  CalibrationOutcome out =
      navigation(rq, o, rq.known_table_errors ? std::nullopt : std::optional(d));
  if (!direct_complete) {
    out.why_method =
        "navigation-based: the direct calibration does not determine every "
        "coefficient plausibly on the " +
        counts;
    return out;
  }
  if (out.status.IsSolutionUsable()) {
    out.why_method = "navigation-based: the direct calibration is unusable (" + d.status.message +
                     "); the navigation-based calibration estimates the table errors it takes "
                     "as nominal";
    return out;
  }
  // Neither fits: the first choice (the direct calibration) with its findings, then why the
  // navigation-based calibration did not help.
  const FitStatus nav = out.status;
  out = fromDirect(d, o);
  out.why_method = "direct: it determines every coefficient from the " + counts +
                   "; the navigation-based calibration was tried as well and is not usable";
  out.status.reasons.push_back("the navigation-based calibration was tried as well: " +
                               nav.message);
  for (const std::string& r : nav.reasons) out.status.reasons.push_back("navigation: " + r);
  out.status.misfit = out.status.misfit || nav.misfit;
  return out;
}

// The sigma check of the method that gave the coefficients (ServiceOptions::sigma_check).
void attachSigmaCheck(const CalibrationRequest& rq, const ServiceOptions& o,
                      CalibrationOutcome* out) {
  if (!o.sigma_check.enabled) {
    out->sigma_check.why_not = "not asked for";
  } else if (out->method == ServiceMethod::kNavigation && out->refined) {
    out->sigma_check = out->refined->sigma_check;
  } else if (out->method == ServiceMethod::kDirect && out->direct && out->status.HasResult()) {
    out->sigma_check =
        jackknifeDirect(rq.recording, directOptions(rq, o), *out->direct, o.sigma_check);
    raiseSigmas(&out->coefficients, &out->sigma_check);
  } else {
    out->sigma_check.why_not = "no result to check";
  }
}

}  // namespace

const char* serviceMethodName(ServiceMethod m) {
  switch (m) {
    case ServiceMethod::kAuto:
      return "auto";
    case ServiceMethod::kDirect:
      return "direct";
    case ServiceMethod::kNavigation:
      return "navigation";
  }
  return "?";
}

bool gyroReferenced(ServiceMethod method) {
  return method == ServiceMethod::kNavigation;
}

bool ServiceOptions::IsValid(std::string* why) const {
  if (!(nonorthogonality_significance_sigma >= 0.0)) {
    return invalidOption(why, "nonorthogonality_significance_sigma must be >= 0");
  }
  if (!(max_start_scale_deviation > 0.0)) {
    return invalidOption(why, "max_start_scale_deviation must be > 0");
  }
  if (direct_unknowns_per_axis < 1) {
    return invalidOption(why, "direct_unknowns_per_axis must be >= 1");
  }
  return direct.IsValid(why) && indirect.IsValid(why) && checks.IsValid(why) &&
         sigma_check.IsValid(why);
}

std::vector<std::string> CalibrationOutcome::estimatedTableParams() const {
  std::vector<std::string> out;
  for (const TableParamDecision& d : table) {
    if (d.estimated) out.push_back(d.name);
  }
  return out;
}

CalibrationOutcome calibrateRecording(const CalibrationRequest& rq, const ServiceOptions& o) {
  CalibrationOutcome out;
  std::string why;
  if (!o.IsValid(&why)) {
    out.status = FitStatus::Failed("invalid options: " + why);
    return out;
  }
  if (rq.direct && rq.direct->geometry.kind != rq.recording.geometry.kind) {
    out.status = FitStatus::Failed(
        "the direct recording and the recording were made on different table kinds: not the "
        "same table");
    return out;
  }
  CalibrationOutcome motion;
  countMotion(rq.recording, o, &motion);
  const std::string counts =
      std::to_string(motion.holds) + " holds and " + std::to_string(motion.runs) + " rotation runs";
  switch (rq.method) {
    case ServiceMethod::kDirect:
      out = fromDirect(calibrateDirect(rq.recording, directOptions(rq, o)), o);
      out.why_method = "direct: asked for";
      break;
    case ServiceMethod::kNavigation:
      out = navigation(rq, o, std::nullopt);
      out.why_method = "navigation-based: asked for";
      break;
    case ServiceMethod::kAuto:
      if (rq.start || rq.direct) {
        out = navigation(rq, o, std::nullopt);
        out.why_method = rq.start ? "navigation-based: start values given"
                                  : "navigation-based: a direct-plan recording and a "
                                    "navigation recording (the production pipeline)";
      } else if (motion.runs == 0) {
        out = fromDirect(calibrateDirect(rq.recording, directOptions(rq, o)), o);
        out.why_method = "direct: the recording holds " + counts +
                         "; without rotation runs there is nothing to navigate";
      } else {
        out = automatic(rq, o, counts);
      }
      break;
  }
  out.holds = motion.holds;
  out.runs = motion.runs;
  attachSigmaCheck(rq, o, &out);
  out.table = tableDecisions(rq.recording.geometry.kind, out.method, rq, indirectOptions(rq, o));
  return out;
}

}  // namespace imubench::calib
