// imubench explain RUN_OR_DIR [RUN_OR_DIR ...] [--coeffs C.json] [--direct RUN_OR_DIR] [--json
// FILE]
//                             [--report DIR] [--effects id,id,...] [--bin S] [--db PATH]
//                             [--propose-plan OUT.toml [--bench BENCH.toml] [--max-duration S]
//                              [--precision F]]   (tools/cli_explain_propose.h)
// imubench explain FILE --format imutk --gyro GYRO_FILE [--latitude DEG --height M | --gravity G]
// imubench explain FILE --format imucal|mikov [--rate HZ] [--gravity G]
//
// Examples:
//   imubench explain /tmp/rec12                       (baseline calibrated from the recording)
//   imubench explain /tmp/rec12 --direct /tmp/recdirect --report /tmp/rep --json /tmp/x.json
//   imubench explain /tmp/rec12 --coeffs coef.json --effects lever_arm,time_delay
//   imubench explain 12 --db lab.db                   (run 12 of the store)
//   imubench explain ../shared/data/real/imutk_xsens_acc.txt --format imutk
//       --gyro ../shared/data/real/imutk_xsens_gyro.txt --latitude 45.4 --height 12
//
// The model-discrepancy analysis (calib/explain/explain.h, docs/explain.md): where the bench's
// forward model misses the recording, which physics it left out, how much, and how much better the
// fit is with it. The baseline it starts from:
//   --coeffs FILE    given coefficients (interchange coefficient file); the recording refits
//                    them jointly with any accepted effect; a file far from what the recording
//                    shows (another IMU, another range setting) is refused;
//   --direct RUN_OR_DIR  the production pipeline (direct calibration of that recording,
//                    navigation-based refinement over both): base tilt and nonorthogonality
//                    are then part of the baseline;
//   neither          calibrated from the recording itself with the method its motion supports
//                    (calib/explain/explain_baseline.h), said on the first lines.
// --format imutk|imucal|mikov: a recording without table angles (static poses of unknown attitude):
// the scalar model (calib/explain/explain_scalar.h) on its static poses.
// --gyro-range DPS / --accel-range G (every --format): samples whose calibrated rate or
// specific force reaches the IMU's range are clipped: refused (exit 1, the sample named).
// Exit codes (the same as `imubench calibrate`): 0 the analysis ran (whether or not it found
// anything); 1 bad input (unreadable, NaN, gaps, clipped samples, coefficients of another
// IMU); 2 usage; 3 result unusable: the recording cannot support the analysis (its motion
// cannot determine the baseline, too few or too short static poses) or its data contradict the
// time axis (a --rate that is not the recording's: gyro scales or integrated rotation a factor
// off); the reason is printed.
// Several recordings (explain A B ...: a recording and the follow-up its --propose-plan
// designed, same IMU and bench): A's analysis alone, then one model over all of them
// (calib::explainRecordings); each group A could not separate is reported resolved (values
// and sigmas: achieved, and the design's from the regressors and noise floors alone) or still
// unseparable. The baseline options apply to A. Recordings of different IMU serials or of
// another bench are refused (exit 1).
// Output: a summary on stdout; --json FILE the interchange report (imubench-explain/1);
// --report DIR a self-contained DIR/report.html (io/explain_report.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "calib/explain/explain.h"
#include "calib/explain/explain_baseline.h"
#include "calib/explain/explain_scalar.h"
#include "calib/recording_checks.h"
#include "io/explain_report.h"
#include "io/import_real.h"
#include "io/recording.h"
#include "io/sim_recording.h"
#include "io/truth_file.h"
#include "tools/cli_common.h"
#include "tools/cli_explain_propose.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

struct ExplainCliOptions {
  std::vector<std::string> inputs;  // RUN_OR_DIR ...; with --format, the file
  std::string input;                // inputs[0]
  std::string coeffs;
  std::string direct;
  std::string json_out;
  std::string report_dir;
  std::string effects;  // comma-separated ids
  std::optional<double> bin_s;
  std::string db;
  std::string format = "imubench";
  // --format recordings: --gyro, --rate, --gravity, --latitude, --height (format and path
  // are `format` and `input`).
  RealRecordingOptions real;
  std::optional<double> gyro_range_dps;  // IMU ranges: samples at them are refused
  std::optional<double> accel_range_g;
  ProposeCliOptions propose;  // --propose-plan, --bench, --max-duration, --precision
};

// "Result unusable" (the recording cannot support the analysis): calibrate's exit code.
constexpr int kExitUnusable = kExitResultUnusable;

// Display units of the six channels: SI recordings in ug and deg/h; third-party recordings in
// their own reading units (the analysis runs on readings, not on calibrated quantities).
struct ChannelUnits {
  std::array<double, 6> per{1, 1, 1, 1, 1, 1};  // reading units per display unit
  std::array<std::string, 6> name;
};

ChannelUnits siUnits() {
  ChannelUnits u;
  for (int c = 0; c < 6; ++c) {
    u.per[static_cast<std::size_t>(c)] = c < 3 ? 9.80665e-6 : kDegToRad / 3600.0;
    u.name[static_cast<std::size_t>(c)] = c < 3 ? "ug" : "deg/h";
  }
  return u;
}

// The analysis's input recording and baseline, with the lines that say where it came from.
struct Prepared {
  ChannelUnits units = siUnits();
  calib::ExplainInput input;      // its recording viewed in the caller's io::CalibrationView
  std::vector<std::string> said;  // printed before the result
};

std::vector<std::string> splitIds(const std::string& list) {
  std::vector<std::string> ids;
  std::stringstream ss(list);
  std::string id;
  while (std::getline(ss, id, ',')) {
    if (!id.empty()) ids.push_back(id);
  }
  return ids;
}

// --effects: every id must be an interchange effect id the analysis knows.
std::vector<std::string> checkedEffects(const std::string& list) {
  std::vector<std::string> ids = splitIds(list);
  calib::ExplainOptions all;
  std::vector<std::string> known;
  for (const calib::ExplainCandidateSpec& c : calib::registryCandidates(all)) {
    known.push_back(c.id);
  }
  for (const char* t : {"base_tilt", "nonorthogonality", "encoder_zero", "mounting"}) {
    known.emplace_back(t);
  }
  for (const std::string& id : ids) {
    if (std::find(known.begin(), known.end(), id) == known.end()) {
      std::string all_ids;
      for (const std::string& k : known) all_ids += (all_ids.empty() ? "" : ",") + k;
      throw CommandFailed("--effects: '" + id + "' is not an effect id (known: " + all_ids + ")",
                          2);
    }
  }
  return ids;
}

// Table groups a given coefficient file carries (nonzero): the baseline estimated them.
std::vector<std::string> givenTableParams(const calib::CoefficientReport& r,
                                          calib::TableKind kind) {
  calib::BenchTruth t = r.values;
  t.table_kind = kind;
  std::vector<std::string> out;
  for (const std::string& n : calib::tableFlatNames(kind)) {
    if (calib::flatValue(t, n).value_or(0.0) != 0.0 || r.uncertainty.count(n) != 0) {
      out.push_back(n);
    }
  }
  return out;
}

void baselineFromFile(const ExplainCliOptions& o, Prepared* p) {
  const io::CoefficientFileResult f = io::readCoefficientFile(o.coeffs);
  if (!f.status.ok) throw CommandFailed(f.status.message);
  p->input.baseline = f.value;
  p->input.baseline_method = "given";
  p->input.baseline_table_params = givenTableParams(f.value, p->input.geometry.kind);
  p->said.push_back("baseline: the coefficients of " + o.coeffs +
                    " (refitted jointly with any accepted effect)");
}

void baselineFromPipeline(const ExplainCliOptions& o, const ResolvedRecording& src, Prepared* p) {
  const ResolvedRecording d = loadRunOrDir(o.direct, o.db);
  const io::CalibrationView dview(d.recording);
  const calib::BaselineCalibration b = calib::calibrateBaseline(p->input.recording(), dview.view());
  if (!b.status.HasResult())
    throw CommandFailed(src.label + " + " + d.label + ": baseline: " + b.status.message);
  p->input.baseline = b.coefficients;
  p->input.baseline_method = b.method;
  p->input.baseline_table_params = b.table_params;
  p->input.baseline_from_this_recording = false;  // the direct recording took part
  p->said.push_back("baseline: the production pipeline (direct calibration of " + d.label +
                    ", navigation-based refinement over both recordings, " +
                    std::to_string(b.passes) + " pass(es))");
}

void baselineFromRecording(const ResolvedRecording& src, Prepared* p) {
  const calib::BaselineCalibration b = calib::calibrateBaseline(p->input.recording());
  if (!b.status.HasResult()) throw CommandFailed(src.label + ": baseline: " + b.status.message);
  p->input.baseline = b.coefficients;
  p->input.baseline_method = b.method;
  p->input.baseline_table_params = b.table_params;
  p->said.push_back("baseline: " + b.method + " calibration of " + src.label +
                    " (no --coeffs: the method its motion supports)");
  for (const std::string& n : b.notes) p->said.push_back("  " + n);
}

// ---- The summary on stdout ----

void printRms(const ChannelUnits& units, const calib::ExplainResult& r) {
  const bool judged = !r.noise.anyResolutionLimited();
  std::printf("residual RMS over %zu bins (before -> after; noise alone; %s):\n", r.bins.size(),
              judged ? "normalised after the refit, limit" : "no noise floor: noise-free data");
  for (int c = 0; c < 6; ++c) {
    const std::size_t k = static_cast<std::size_t>(c);
    const double u = units.per[k];
    std::printf("  %-8s %10.4g -> %10.4g %-8s", calib::explainChannelName(c), r.rms_before[k] / u,
                r.rms_after[k] / u, units.name[k].c_str());
    if (!judged) {
      std::printf("  (noise not measurable: %d distinct reading(s) per hold)\n",
                  r.noise.distinct_values[k]);
      continue;
    }
    std::printf("  (noise %.4g; %.2fx -> %.2fx; limit %.2fx%s)\n", r.noise_rms[k] / u,
                r.noise_rms[k] > 0 ? r.rms_before[k] / r.noise_rms[k] : 0.0,
                r.channel_normalised_rms[k], r.channel_limit[k],
                r.channel_normalised_rms[k] > r.channel_limit[k] ? ", ABOVE the floor" : "");
  }
  if (judged) {
    std::printf("normalised residual RMS %.3f -> %.3f (1 = the noise floor)\n",
                r.baseline_normalised_rms, r.after_normalised_rms);
  } else {
    std::printf("normalised residual RMS: not meaningful (no noise floor)\n");
  }
  std::printf("joint refit: Gauss-Newton, %d step(s), %s (last step %.2g sigma)\n",
              r.refit.iterations, r.refit.converged ? "converged" : "NOT converged",
              r.refit.last_step_sigma);
}

void printWindows(const ChannelUnits& units, const calib::ExplainResult& r, const char* what,
                  const std::vector<calib::ExplainWindow>& ws) {
  const std::size_t shown = std::min<std::size_t>(ws.size(), 8);
  std::printf("%s: %zu window(s)%s\n", what, ws.size(), ws.empty() ? "" : ", largest first:");
  std::vector<calib::ExplainWindow> sorted = ws;
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return std::abs(a.sigma) > std::abs(b.sigma); });
  for (std::size_t k = 0; k < shown; ++k) {
    const calib::ExplainWindow& w = sorted[k];
    const std::size_t c = static_cast<std::size_t>(w.channel);
    const auto [rec, t0] = calib::explainRecordingTime(r, w.t0);
    if (!r.recording_offsets_s.empty()) std::printf("  rec%d", rec + 1);
    std::printf("  %9.1f-%9.1f s  %-7s %+8.1f sigma  (%+.4g %s)  %s\n", t0, t0 + (w.t1 - w.t0),
                calib::explainChannelName(w.channel), w.sigma, w.mean / units.per[c],
                units.name[c].c_str(), w.reason.c_str());
  }
}

void printEffects(const calib::ExplainResult& r) {
  if (r.accepted.empty()) {
    std::printf("accepted effects: none (nothing in the library is warranted by this recording)\n");
  }
  for (const calib::ExplainAccepted& a : r.accepted) {
    std::printf("accepted %s: delta BIC %.1f, LR %.1f, p %.3g\n", a.effect.c_str(), a.delta_bic,
                a.lr_stat, a.p_value);
    for (std::size_t k = 0; k < a.values.size(); ++k) {
      const std::string& n = a.flat_names[k];
      if (std::isnan(a.sigmas[k]) && n.size() > 5 && n.compare(n.size() - 5, 5, ".axis") == 0) {
        std::printf("    %-36s %s  (held: the axis that fits best)\n", n.c_str(),
                    calib::tableAxisName(static_cast<int>(a.values[k])));
      } else if (std::isnan(a.sigmas[k]) && n.size() > 6 &&
                 n.compare(n.size() - 6, 6, ".order") == 0) {
        std::printf("    %-36s %d  (held: the order that fits best)\n", n.c_str(),
                    static_cast<int>(a.values[k]));
      } else if (!std::isfinite(a.sigmas[k])) {
        std::printf("    %-36s %+.6g  (SI; sigma not determined: held in the refit)\n", n.c_str(),
                    a.values[k]);
      } else {
        std::printf("    %-36s %+.6g  sigma %.3g (SI)\n", n.c_str(), a.values[k], a.sigmas[k]);
      }
    }
  }
  for (const calib::ExplainRejected& x : r.rejected) {
    std::printf("rejected %s: %s\n", x.effect.c_str(), x.reason.c_str());
  }
  for (const calib::ExplainUnseparable& u : r.unseparable) {
    std::printf("unseparable: %s\n", u.reason.c_str());
  }
}

// The indirect method's navigation residual of each run: the end attitude about the two
// horizontal axes, arcsec, at the baseline and after the refit.
void printRunResiduals(const calib::ExplainResult& r) {
  if (r.runs.empty()) return;
  constexpr double kArcsec = 180.0 / 3.14159265358979323846 * 3600.0;
  std::printf(
      "navigation residual per run (end attitude about the horizontal axes, arcsec; "
      "baseline -> refit; sigma from the gyro noise):\n");
  for (const calib::ExplainRunResidual& n : r.runs) {
    const double t0 = calib::explainRecordingTime(r, n.t0).second;  // its recording's clock
    std::printf("  %-24s %8.1f-%8.1f s  x %+8.2f -> %+8.2f  y %+8.2f -> %+8.2f  sigma %.2f\n",
                n.label.c_str(), t0, t0 + (n.t1 - n.t0), n.before[0] * kArcsec,
                n.after[0] * kArcsec, n.before[1] * kArcsec, n.after[1] * kArcsec,
                n.sigma * kArcsec);
  }
}

void printSummary(const Prepared& p, const calib::ExplainResult& r) {
  for (const std::string& s : p.said) std::printf("%s\n", s.c_str());
  std::printf("noise floor (white, per sqrt(Hz)):");
  for (int c = 0; c < 6; ++c) {
    const std::size_t k = static_cast<std::size_t>(c);
    std::printf(" %s %.3g %s", calib::explainChannelName(c), r.noise.white[k] / p.units.per[k],
                p.units.name[k].c_str());
  }
  std::printf("\n");
  printRms(p.units, r);
  printWindows(p.units, r, "located (baseline residual beyond the noise floor)", r.located);
  printRunResiduals(r);
  printEffects(r);
  if (!r.unexplained.empty()) {
    printWindows(p.units, r, "UNEXPLAINED (nothing in the library accounts for these)",
                 r.unexplained);
  }
  std::printf("unexplained: %s\n", calib::explainVerdict(r).c_str());
  for (const std::string& n : r.notes) std::printf("note: %s\n", n.c_str());
}

// extra: keys added to the report JSON (the --propose-plan proposal).
void writeOutputs(const ExplainCliOptions& o, const std::string& label,
                  const calib::ExplainResult& r, const nlohmann::json& extra = {}) {
  if (!o.json_out.empty()) {
    nlohmann::json j = calib::toJson(r);
    if (extra.is_object()) j.update(extra);
    const Status s = io::writeJsonFile(o.json_out, j);
    if (!s.ok) throw CommandFailed(s.message);
    std::printf("report JSON written to %s\n", o.json_out.c_str());
  }
  if (!o.report_dir.empty()) {
    const Status s = io::writeExplainReport(o.report_dir, r, label);
    if (!s.ok) throw CommandFailed(s.message);
    std::printf("report written to %s/report.html\n", o.report_dir.c_str());
  }
}

calib::ExplainOptions analysisOptions(const ExplainCliOptions& o) {
  calib::ExplainOptions eo;
  if (o.gyro_range_dps) eo.checks.gyro_range_radps = *o.gyro_range_dps * kDegToRad;
  if (o.accel_range_g) eo.checks.accel_range_mps2 = *o.accel_range_g * 9.80665;
  if (!o.effects.empty()) eo.candidates = checkedEffects(o.effects);
  if (o.bin_s) eo.model.bin_s = *o.bin_s;
  std::string why;
  if (!eo.IsValid(&why)) throw CommandFailed("options: " + why, 2);
  return eo;
}

void refuseTwoBaselines(const ExplainCliOptions& o) {
  if (!o.coeffs.empty() && !o.direct.empty()) {
    throw CommandFailed("--coeffs and --direct both give the baseline: choose one", 2);
  }
}

// The baseline of a table recording (p->input holds its view): --coeffs, --direct, or
// calibrated from the recording itself.
void baselineOf(const ExplainCliOptions& o, const ResolvedRecording& src, Prepared* p) {
  refuseInconsistentTime(src.label, p->input.recording());
  if (!o.coeffs.empty()) {
    baselineFromFile(o, p);
  } else if (!o.direct.empty()) {
    baselineFromPipeline(o, src, p);
  } else {
    // Refused before any calibration: a baseline the motion cannot determine is noise.
    if (const std::string why = calib::explainMotionRefusal(p->input.recording()); !why.empty()) {
      throw CommandFailed(src.label + ": " + why + " (result unusable, exit 3)", kExitUnusable);
    }
    baselineFromRecording(src, p);
  }
}

std::string describe(const ResolvedRecording& src) {
  return "explain " + src.label + ": " + std::to_string(src.recording.imu.size()) +
         " IMU samples, " + std::to_string(src.recording.segments.size()) + " segments";
}

void runExplainTable(const ExplainCliOptions& o) {
  refuseTwoBaselines(o);
  const calib::ExplainOptions eo = analysisOptions(o);
  const ResolvedRecording src = loadRunOrDir(o.input, o.db);
  const io::CalibrationView view(src.recording);
  Prepared p;
  p.input.recording() = view.view();
  p.said.push_back(describe(src));
  baselineOf(o, src, &p);
  const calib::ExplainResult r = calib::explainRecording(p.input, eo);
  if (!r.status.ok) {
    throw CommandFailed(src.label + ": explain: " + r.status.message,
                        r.unusable ? kExitUnusable : 1);
  }
  printSummary(p, r);
  nlohmann::json extra = nlohmann::json::object();
  if (!o.propose.out.empty()) extra["proposal"] = proposeFromExplain(o.propose, p.input, r, eo);
  writeOutputs(o, src.label, r, extra);
}

const calib::ExplainAccepted* acceptedEffect(const calib::ExplainResult& r, const std::string& id) {
  for (const calib::ExplainAccepted& a : r.accepted) {
    if (a.effect == id) return &a;
  }
  return nullptr;
}

// What became of each group the first recording could not separate: per effect accepted
// (values, achieved sigmas and the design's: regressors and noise floors without the refit's
// misfit, what --propose-plan predicts) or not warranted, or the group still unseparable.
void printGroups(const std::string& label, const calib::ExplainResult& alone,
                 const calib::ExplainResult& joint) {
  if (alone.unseparable.empty()) {
    std::printf("groups unseparable in %s alone: none\n", label.c_str());
    return;
  }
  const double misfit = std::sqrt(std::max(1.0, joint.refit.chi2_per_dof));
  std::printf(
      "groups unseparable in %s alone (sigma achieved; design: the regressors and noise floors "
      "alone, achieved / %.3g for the refit's misfit):\n",
      label.c_str(), misfit);
  for (const calib::ExplainUnseparable& u : alone.unseparable) {
    std::string ids;
    for (const std::string& e : u.effects) ids += (ids.empty() ? "" : " + ") + e;
    bool still = false;
    for (const calib::ExplainUnseparable& v : joint.unseparable) still |= v.effects == u.effects;
    std::printf("  %s: %s\n", ids.c_str(), still ? "STILL UNSEPARABLE" : "resolved");
    if (still) continue;
    for (const std::string& e : u.effects) {
      const calib::ExplainAccepted* a = acceptedEffect(joint, e);
      if (a == nullptr) {
        std::printf("    %s: not warranted (see rejected)\n", e.c_str());
        continue;
      }
      for (std::size_t k = 0; k < a->values.size(); ++k) {
        if (!std::isfinite(a->sigmas[k])) continue;
        std::printf("    %-36s %+.6g  sigma %.3g (design %.3g) (SI)\n", a->flat_names[k].c_str(),
                    a->values[k], a->sigmas[k], a->sigmas[k] / misfit);
      }
    }
  }
}

// explain A B ...: A's analysis alone (its groups), then one model over every recording.
void runExplainJoint(const ExplainCliOptions& o) {
  if (!o.propose.out.empty()) {
    throw CommandFailed("--propose-plan takes one recording (the one whose groups it separates)",
                        2);
  }
  refuseTwoBaselines(o);
  const calib::ExplainOptions eo = analysisOptions(o);
  std::vector<std::unique_ptr<ResolvedRecording>> srcs;
  std::vector<std::unique_ptr<io::CalibrationView>> views;  // the inputs view their recordings
  std::vector<calib::ExplainInput> inputs;
  Prepared p;
  for (const std::string& path : o.inputs) {
    srcs.push_back(std::make_unique<ResolvedRecording>(loadRunOrDir(path, o.db)));
    const ResolvedRecording& src = *srcs.back();
    const std::string& serial0 = srcs.front()->recording.imu_serial;
    if (!serial0.empty() && !src.recording.imu_serial.empty() &&
        src.recording.imu_serial != serial0) {
      throw CommandFailed(src.label + ": IMU serial '" + src.recording.imu_serial + "', " +
                          srcs.front()->label + ": '" + serial0 +
                          "': a joint analysis is of one IMU");
    }
    views.push_back(std::make_unique<io::CalibrationView>(src.recording));
    inputs.emplace_back();
    inputs.back().recording() = views.back()->view();
    p.said.push_back(describe(src));
    if (inputs.size() > 1) refuseInconsistentTime(src.label, inputs.back().recording());
  }
  p.input = inputs[0];
  baselineOf(o, *srcs[0], &p);
  inputs[0] = p.input;
  const calib::ExplainResult alone = calib::explainRecording(p.input, eo);
  if (!alone.status.ok) {
    throw CommandFailed(srcs[0]->label + ": explain: " + alone.status.message,
                        alone.unusable ? kExitUnusable : 1);
  }
  const calib::ExplainResult r = calib::explainRecordings(inputs, eo);
  if (!r.status.ok)
    throw CommandFailed("joint explain: " + r.status.message, r.unusable ? kExitUnusable : 1);
  for (std::size_t k = 1; k < r.recording_offsets_s.size(); ++k) {
    p.said.push_back("recording " + std::to_string(k + 1) + " (" + srcs[k]->label + ") starts at " +
                     std::to_string(r.recording_offsets_s[k]) + " s on the joint time axis");
  }
  printSummary(p, r);
  printGroups(srcs[0]->label, alone, r);
  writeOutputs(o, srcs[0]->label + " + " + std::to_string(srcs.size() - 1) + " more", r);
}

void runExplainScalar(const ExplainCliOptions& o) {
  if (!o.propose.out.empty()) {
    throw CommandFailed("--propose-plan needs a table recording (a plan moves a table)", 2);
  }
  if (!o.coeffs.empty() || !o.direct.empty()) {
    throw CommandFailed("--format " + o.format +
                            " recordings are explained from their own scalar calibration: no "
                            "--coeffs or --direct",
                        2);
  }
  const calib::ExplainOptions eo = analysisOptions(o);
  RealRecordingOptions ro = o.real;
  ro.format = o.format;
  ro.path = o.input;
  ro.gyro_range_dps = o.gyro_range_dps;
  ro.accel_range_g = o.accel_range_g;
  const RealRecording real = readRealRecording(ro);
  const io::RealImport& in = real.import;
  const calib::ScalarCalibrationOptions& so = real.scalar;
  const bool accel_si = real.accel_si;
  const calib::ExplainResult r = calib::explainScalar(in.data, so, accel_si, eo);
  if (!r.status.ok) {
    throw CommandFailed(o.input + ": explain: " + r.status.message, r.unusable ? kExitUnusable : 1);
  }
  refuseInconsistentRate(ro, real, r.coefficients.values.sensors.gyro);
  Prepared p;
  for (std::size_t c = 0; c < 6; ++c) {
    if (c >= 3 || !accel_si) {
      p.units.per[c] = 1.0;
      p.units.name[c] = c < 3 ? in.accel_unit : in.gyro_unit;
    }
  }
  p.said.push_back("explain " + o.input + " (" + o.format + ", " + std::to_string(in.data.size()) +
                   " samples, accel in " + in.accel_unit + ", gyro in " + in.gyro_unit +
                   ", g = " + std::to_string(so.gravity_mps2) + " m/s^2)");
  p.said.push_back(
      "baseline: scalar calibration of the recording's static poses (no table: the poses' "
      "attitudes are unknowns; residuals are of the accelerometer triad on the poses and of the "
      "gyro at rest)");
  printSummary(p, r);
  writeOutputs(o, o.input, r);
}

}  // namespace

void addExplainCommand(CLI::App& app) {
  auto opt = std::make_shared<ExplainCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "explain",
      "where the model misses a recording, what physics it left out, how much, and how much "
      "better the fit is with it (docs/explain.md)");
  sub->add_option("RUN_OR_DIR", opt->inputs,
                  "imubench-csv/1 directory or run id (N, run:N); with --format, the file; "
                  "several: one model over all (the first's groups resolved or not)")
      ->required();
  sub->add_option("--coeffs", opt->coeffs, "baseline coefficients (interchange coefficient file)");
  sub->add_option("--direct", opt->direct,
                  "direct plan's recording of the same IMU and table: the pipeline's baseline");
  sub->add_option("--json", opt->json_out, "write the imubench-explain/1 report here");
  sub->add_option("--report", opt->report_dir, "write DIR/report.html (self-contained)");
  sub->add_option("--effects", opt->effects,
                  "candidate effect ids, comma-separated (default: the whole library)");
  sub->add_option("--bin", opt->bin_s, "bin length, s (default 0.5)");
  addStoreOption(*sub, &opt->db);
  sub->add_option("--format", opt->format,
                  "imubench (default), imutk, imucal or imu-calib (alias mikov)")
      ->check(CLI::IsMember({"imubench", "imutk", "imucal", "imu-calib", "mikov"}));
  sub->add_option("--gyro", opt->real.gyro_file, "imutk: the gyro file of the pair");
  sub->add_option("--rate", opt->real.rate_hz, "imucal, mikov: sampling rate, Hz");
  sub->add_option("--gravity", opt->real.gravity, "local gravity, m/s^2");
  sub->add_option("--latitude", opt->real.latitude_deg, "latitude, deg (gravity and Earth rate)");
  sub->add_option("--height", opt->real.height_m, "height, m");
  sub->add_option("--gyro-range", opt->gyro_range_dps,
                  "IMU gyro range, deg/s: samples at it are clipped and the recording is refused")
      ->check(CLI::PositiveNumber);
  sub->add_option("--accel-range", opt->accel_range_g,
                  "IMU accelerometer range, g: samples at it are clipped and the recording is "
                  "refused")
      ->check(CLI::PositiveNumber);
  sub->add_option("--propose-plan", opt->propose.out,
                  "write the plan that separates what this recording could not (plan TOML)");
  sub->add_option("--bench", opt->propose.bench,
                  "bench file whose [table] max_rate/max_accel bound the proposal (default: the "
                  "virtual bench's 30 deg/s, 10 deg/s^2)");
  sub->add_option("--max-duration", opt->propose.max_duration_s,
                  "longest proposed plan, s (default 7200)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--precision", opt->propose.precision,
                  "wanted sigma of an accepted effect as a fraction of its size (default 0.1)")
      ->check(CLI::PositiveNumber);
  sub->callback([opt] {
    opt->input = opt->inputs.front();
    if (opt->format == "imubench" && opt->inputs.size() > 1) {
      runExplainJoint(*opt);
    } else if (opt->format == "imubench") {
      runExplainTable(*opt);
    } else if (opt->inputs.size() > 1) {
      throw CommandFailed("--format " + opt->format + ": one recording file", 2);
    } else {
      runExplainScalar(*opt);
    }
  });
}

}  // namespace imubench::tools
