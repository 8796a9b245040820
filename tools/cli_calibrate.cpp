// imubench calibrate DIR [--method direct|indirect|scalar] [--json] [--out FILE] [--start FILE]
//                        [--direct DIRECT_DIR] [--table-errors FILE] [--truth T.json]
//                        [--db PATH] [--store-result]
// imubench calibrate FILE --format imutk --gyro GYRO_FILE [--latitude DEG --height M | --gravity G]
// imubench calibrate FILE --format imucal [--rate HZ] [--gravity G]
//
// Examples:
//   imubench calibrate /tmp/rec --method indirect --json --out coef.json
//   imubench calibrate /tmp/rec12 --method indirect --direct /tmp/recdirect   (the pipeline)
//   imubench calibrate ../shared/data/real/imutk_xsens_acc.txt --format imutk
//       --gyro ../shared/data/real/imutk_xsens_gyro.txt --latitude 45.4 --height 12
//   imubench calibrate ../shared/data/real/imucal_example_ferraris_session.csv --format imucal
//   imubench calibrate 12 --direct run:11 --db lab.db --store-result   (runs of the store)
//
// DIR and DIRECT_DIR are RUN_OR_DIR arguments (tools/cli_store.h): a recording directory, or a
// run id (N or run:N) of the run store given by --db. --store-result stores the coefficient
// JSON (what --out writes) as a result of kind "coefficients" of the run DIR names, with the
// recording's IMU serial and mean temperature (IMU temperature, else the chamber's).
// Reads an imubench-csv/1 recording (or, with --format, a third-party recording without table
// angles: scalar calibration only) and calibrates it through the one calibration service
// (calib/service/calibration_service.h), which the daemon and explain's baseline call too. Without
// --method the service picks what the motion supports and says why: holds only -> direct;
// holds and rotation runs -> direct when the direct calibration determines every coefficient
// and is usable, else the navigation-based calibration, which estimates the table errors the
// direct calibration takes as nominal. The methods:
//   direct    the table-based direct calibration (calib/direct_calibration.h);
//   indirect  the navigation-based calibration (calib/indirect/indirect_calibration.h), started
//   from the
//             direct calibration of the same recording (or --start FILE, a coefficient file);
//             with --direct DIRECT_DIR (the direct plan's recording of the same device on the
//             same table) the production pipeline of calib/indirect/bench_calibration.h: direct
//             calibration of DIRECT_DIR, refinement over both recordings, second pass when the
//             table's axes are nonorthogonal;
//   scalar    the table-free field calibration (calib/scalar/scalar_calibration.h).
// --method indirect without --start runs the pipeline with DIR as its own direct recording.
// --table-errors FILE (a coefficient/truth file's "table": the table's certification data)
// gives the table errors known beforehand to every method: direct calibration takes the
// chain with them, the refinement holds the nonorthogonality at them and starts the base
// tilt there.
// Exit codes: 0 usable result; 1 bad input or failed calibration; 2 usage; 3 the calibration
// ran but its result is unusable (residuals far above the noise, a coefficient the data do
// not determine, implausible values): the findings and the largest residuals are printed,
// nothing is written.
// Prints the coefficients with sigmas in engineering units (ppm, ug, deg/h, arcsec) and what
// the plan cannot see; --json prints the interchange coefficient JSON instead (with "sigma"
// and "observable": false), --out FILE writes it.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include "calib/fit_quality.h"
#include "calib/scalar/scalar_calibration.h"
#include "calib/scalar/scalar_consistency.h"
#include "calib/segment_check.h"
#include "calib/service/calibration_service.h"
#include "calib/truth_comparison.h"
#include "io/import_real.h"
#include "io/recording.h"
#include "io/sim_recording.h"
#include "io/truth_file.h"
#include "nav/free_navigation.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

struct CalibrateOptions {
  std::string dir;
  std::string method;  // empty: the service's choice; scalar without table angles or with --format
  std::string format = "imubench";
  std::string gyro_file;                      // imutk: the gyro file of the pair
  double rate_hz = io::kImucalExampleRateHz;  // imucal: sampling rate
  bool rate_hz_given = false;                 // --rate on the command line (mikov: 100 Hz)
  std::optional<double> gravity;              // m/s^2; else from --latitude/--height
  std::optional<double> latitude_deg;
  double height_m = 0.0;
  bool json = false;
  bool sigma_check = true;  // the resampling check of the sigmas (--no-sigma-check: off)
  std::string out;
  std::string start;
  std::string direct_dir;                // indirect: the direct plan's recording (pipeline)
  std::string truth;                     // compare the estimate with this truth file
  std::string table_errors;              // known table errors (certification data)
  std::optional<double> gyro_range_dps;  // IMU ranges: samples at them are refused
  std::optional<double> accel_range_g;
  std::string db;             // run store for run ids (tools/cli_store.h)
  bool store_result = false;  // store the coefficients as a result of run `dir`
};

// Mean temperature of a recording for its stored result: the IMU's reported temperature, else
// the chamber's measured one.
std::optional<double> meanTemperature(const io::Recording& rec) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const nav::ImuSample& s : rec.imu) {
    if (std::isfinite(s.temp_c)) {
      sum += s.temp_c;
      ++n;
    }
  }
  if (n == 0) {
    for (const io::ChamberSample& c : rec.chamber) {
      sum += c.temp_c;
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  return sum / static_cast<double>(n);
}

// --store-result: the input must be a stored run with a temperature. Checked before the
// calibration so a refused option costs nothing.
void checkStoreResult(const CalibrateOptions& o, const ResolvedRecording& src) {
  if (!o.store_result) return;
  if (!src.run_id) {
    throw CommandFailed("--store-result needs a run id, not the directory '" + o.dir + "'", 2);
  }
  if (!meanTemperature(src.recording)) {
    throw CommandFailed("--store-result: " + src.label +
                        " has no temperature (no IMU temperature, no chamber samples)");
  }
}

void storeResult(const CalibrateOptions& o, const ResolvedRecording& src,
                 const calib::CoefficientReport& report, std::ostream& info) {
  if (!o.store_result || !src.run_id) return;
  const std::int64_t result_id = storeRunResult(o.db, *src.run_id, src.recording.imu_serial,
                                                meanTemperature(src.recording).value_or(0.0),
                                                "coefficients", calib::toJson(report).dump());
  info << "coefficients stored as result " << result_id << " of " << src.label << " in " << o.db
       << "\n";
}

// Exit code of a calibration that ran but whose result must not be used.
constexpr int kExitUnusable = kExitResultUnusable;

// A scalar calibration that did not give a result: the data cannot determine the coefficients
// (too few or too similar poses, readings that contradict gravity) is "result unusable" (exit
// 3); malformed data (NaN, gaps, time going back) is a plain error (exit 1).
CommandFailed scalarRefusal(const std::string& label, const calib::RecordingCheck& status) {
  const bool unusable = status.code == calib::RecordingStatusCode::kTooFewStatics ||
                        status.code == calib::RecordingStatusCode::kTooShortStatic;
  return CommandFailed(label + ": scalar calibration: " + status.message,
                       unusable ? kExitUnusable : 1);
}

// --table-errors: the table section of a coefficient/truth file (zero when not given).
calib::TableErrors knownTableErrors(const CalibrateOptions& o) {
  if (o.table_errors.empty()) return {};
  return loadTruthOrFail(o.table_errors).table;
}

// One line per coefficient: value and sigma in engineering units.
void printReport(const calib::CoefficientReport& r) {
  const std::vector<std::string> names = calib::flatNames(r.values);
  for (const std::string& n : names) {
    if (n.rfind("extra.", 0) == 0) continue;
    const bool scale = n.find(".scale.") != std::string::npos;
    const calib::DisplayUnit d = calib::displayUnit(n);
    const double unit = d.si_per_unit;
    const char* u = scale ? "ppm (scale - 1)" : d.label;
    double v = calib::flatValue(r.values, n).value_or(0.0);
    if (scale) v -= 1.0;
    const auto it = r.uncertainty.find(n);
    char buf[160];
    if (it != r.uncertainty.end() && !it->second.observable) {
      std::snprintf(buf, sizeof(buf), "  %-34s %14.3f %-16s  not observable (fixed)\n", n.c_str(),
                    v / unit, u);
    } else if (it != r.uncertainty.end() && it->second.sigma) {
      std::snprintf(buf, sizeof(buf), "  %-34s %14.3f %-16s  sigma %.3f\n", n.c_str(), v / unit, u,
                    *it->second.sigma / unit);
    } else {
      std::snprintf(buf, sizeof(buf), "  %-34s %14.3f %-16s  (not estimated)\n", n.c_str(),
                    v / unit, u);
    }
    std::cout << buf;
  }
}

// --truth: the truth put into the frame the method's coefficients refer to.
enum class TruthFrame {
  kGyroReferenced,  // navigation-based: mounting absorbed, outer zero in the tilt
  kAsIs,            // direct / scalar: compared as written (see the note printed)
};

calib::BenchTruth expectedTruth(const calib::BenchTruth& truth, const calib::TableGeometry& g,
                                TruthFrame frame) {
  return frame == TruthFrame::kAsIs ? truth : gyroReferencedTruth(truth, g);
}

nlohmann::json comparisonJson(const calib::TruthComparison& c) {
  nlohmann::json rows = nlohmann::json::array();
  for (const calib::ComparisonRow& r : c.rows) {
    rows.push_back({{"name", r.name},
                    {"estimate", r.estimate},
                    {"expected", r.expected},
                    {"error", r.error},
                    {"sigma", r.sigma},
                    {"unit", r.unit},
                    {"error_in_unit", r.error_in_unit},
                    {"limit_in_unit", r.limit_in_unit},
                    {"within", r.within},
                    {"observable", r.observable}});
  }
  return {{"rows", rows}, {"judged", c.judged}, {"outside", c.outside}};
}

void printComparison(const calib::TruthComparison& c, const std::string& truth_path,
                     TruthFrame frame) {
  std::printf("comparison with %s (%s; targets: 3 arcsec, 10 ppm, biases 2 sigma)\n",
              truth_path.c_str(),
              frame == TruthFrame::kGyroReferenced
                  ? "truth mapped into the gyro-referenced platform frame"
                  : "truth as written: direct/scalar misalignments also carry mounting and "
                    "base tilt, as the seed analyses");
  printComparisonRows(c);
  std::printf(
      "  %d of %d judged parameters within target (a 2-sigma bias bound is a 95 %% statement: "
      "about one bias in twenty lies outside it by chance)\n",
      c.judged - c.outside, c.judged);
}

void emit(const CalibrateOptions& o, const ResolvedRecording& src,
          const calib::CoefficientReport& report, const nlohmann::json& extra,
          const calib::TableGeometry& geometry, TruthFrame frame) {
  std::optional<calib::TruthComparison> cmp;
  if (!o.truth.empty()) {
    cmp = calib::compareWithTruth(report, expectedTruth(loadTruthOrFail(o.truth), geometry, frame));
  }
  if (o.json) {
    nlohmann::json j = calib::toJson(report);
    if (!extra.is_null()) j["calibration"] = extra;
    if (cmp) j["truth_comparison"] = comparisonJson(*cmp);
    std::cout << j.dump(2) << "\n";
  } else {
    printReport(report);
    if (cmp) printComparison(*cmp, o.truth, frame);
  }
  if (!o.out.empty()) {
    const Status s = io::writeCoefficientFile(o.out, report);
    if (!s.ok) throw CommandFailed(s.message);
    if (!o.json) std::cout << "coefficients written to " << o.out << "\n";
  }
  storeResult(o, src, report, o.json ? std::cerr : std::cout);
}

// Third-party recordings (no table angles): the scalar calibration only, in the source's
// reading units (counts, deg/s).
void runCalibrateReal(const CalibrateOptions& o) {
  if (!o.method.empty() && o.method != "scalar") {
    throw CommandFailed("--format " + o.format + " has no table angles: only --method scalar", 2);
  }
  RealRecordingOptions ro;
  ro.format = o.format;
  ro.path = o.dir;
  ro.gyro_file = o.gyro_file;
  if (o.rate_hz_given || o.format == "imucal") ro.rate_hz = o.rate_hz;
  ro.gravity = o.gravity;
  ro.latitude_deg = o.latitude_deg;
  ro.height_m = o.height_m;
  ro.gyro_range_dps = o.gyro_range_dps;
  ro.accel_range_g = o.accel_range_g;
  const RealRecording real = readRealRecording(ro);
  const io::RealImport& in = real.import;
  const calib::ScalarCalibrationOptions& so = real.scalar;
  const bool accel_si = real.accel_si;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(in.data, so, accel_si);
  if (!r.status.ok) throw scalarRefusal(o.dir, r.status);
  refuseInconsistentRate(ro, real, r.gyro());
  std::ostream& info = o.json ? std::cerr : std::cout;
  info << "scalar calibration of " << o.dir << " (" << in.data.size() << " samples, accel in "
       << in.accel_unit << ", gyro in " << in.gyro_unit << ", g = " << so.gravity_mps2
       << " m/s^2)\n"
       << calib::describe(r);
  const calib::ScalarConsistency c = calib::scalarConsistency(in.data, r, so, accel_si);
  info << calib::describe(c);
  calib::SigmaCheckOptions sco;
  sco.enabled = o.sigma_check;
  calib::CoefficientReport report = r.report;
  calib::SigmaCheck check;
  if (sco.enabled) {
    check = calib::sigmaCheckFromHalves(c, report, sco);
    calib::raiseSigmas(&report, &check);
  } else {
    check.why_not = "not asked for";
  }
  info << check.describe();
  if (check.sigmas_raised) {
    for (const auto& [name, rs] : check.resampled_sigma) {
      if (rs > r.report.uncertainty.at(name).sigma.value_or(0.0)) {
        info << "  " << name << ": sigma raised to the resampled " << rs << " (units above)\n";
      }
    }
  }
  if (o.json) {
    nlohmann::json j = calib::toJson(report);
    j["sigma_check"] = calib::toJson(check);
    j["consistency"] = {{"accel_normalised_rms", c.accel_normalised_rms},
                        {"accel_dof", c.accel_dof},
                        {"halves_compared", c.halves_ok},
                        {"halves_rms_z", c.rms_z},
                        {"halves_max_abs_z", c.max_abs_z},
                        {"halves_worst", c.worst},
                        {"halves_note", c.halves_why}};
    j["calibration"] = {{"method", "scalar"},
                        {"accel_unit", in.accel_unit},
                        {"gyro_unit", in.gyro_unit},
                        {"static_poses", r.spans.size()},
                        {"accel_rms_before_mps2", r.accel_rms_before},
                        {"accel_rms_after_mps2", r.accel_rms_after}};
    std::cout << j.dump(2) << "\n";
  }
  if (!o.out.empty()) {
    const Status s = io::writeCoefficientFile(o.out, report);
    if (!s.ok) throw CommandFailed(s.message);
  }
}

calib::IncrementCheckOptions checksOf(const CalibrateOptions& o) {
  calib::IncrementCheckOptions c;
  if (o.gyro_range_dps) c.gyro_range_radps = *o.gyro_range_dps * kDegToRad;
  if (o.accel_range_g) c.accel_range_mps2 = *o.accel_range_g * 9.80665;
  return c;
}

// The --json "calibration" section: which method and why, what the navigation-based method
// reports of its solve, what was done with each table error.
nlohmann::json calibrationJson(const calib::CalibrationOutcome& c) {
  nlohmann::json extra;
  extra["method"] = c.method == calib::ServiceMethod::kDirect
                        ? "direct"
                        : (c.start == "given" ? "indirect" : "pipeline");
  extra["why_method"] = c.why_method;
  if (c.refined) {
    const calib::CalibrationResult& r = *c.refined;
    extra["start"] = c.start;
    extra["passes"] = c.passes;
    extra["conditioning"] = calib::toJson(r.conditioning);
    extra["rms_normalised_residual"] = r.rms_normalised_residual;
    extra["goodness_of_fit"] = {{"accel_holds", r.accel_normalised_rms},
                                {"gyro_holds", r.gyro_normalised_rms},
                                {"runs", r.run_normalised_rms}};
    extra["sigma_factors"] = {{"accel_holds", r.accel_sigma_factor},
                              {"gyro_holds", r.gyro_sigma_factor},
                              {"runs", r.run_sigma_factor}};
  } else if (c.direct) {
    extra["rms_normalised_residual"] = c.direct->normalised_residual_rms;
    extra["goodness_of_fit"] = {{"accel", c.direct->accel_normalised_rms},
                                {"gyro", c.direct->gyro_normalised_rms}};
    extra["sigma_factors"] = {{"accel", c.direct->accel_sigma_factor},
                              {"gyro", c.direct->gyro_sigma_factor}};
  }
  extra["sigma_check"] = calib::toJson(c.sigma_check);
  nlohmann::json table = nlohmann::json::array();
  for (const calib::TableParamDecision& d : c.table) {
    table.push_back({{"name", d.name}, {"estimated", d.estimated}, {"reason", d.reason}});
  }
  extra["table"] = table;
  return extra;
}

void printDirect(std::ostream& info, const std::string& label,
                 const calib::DirectCalibrationResult& d, bool all_notes) {
  info << "direct calibration of " << label << ": " << d.statics_used << " statics, "
       << d.rotations_used << " rotations, normalised residual RMS " << d.normalised_residual_rms
       << " (accel " << d.accel_normalised_rms << ", gyro " << d.gyro_normalised_rms
       << "; 1 = the noise); sigmas scaled by it: accel x" << d.accel_sigma_factor << ", gyro x"
       << d.gyro_sigma_factor << "\n";
  for (const std::string& n : d.notes) {
    if (all_notes || n.rfind("static segments joined", 0) == 0 || n.rfind("segments.csv", 0) == 0) {
      info << "  note: " << n << "\n";
    }
  }
}

void printIndirect(std::ostream& info, const std::string& what, const calib::CalibrationResult& r) {
  for (const std::string& w : r.warnings) info << "  warning: " << w << "\n";
  info << what << ": " << r.outer_iterations << " outer iterations, normalised residual RMS "
       << r.rms_normalised_residual << " (accel holds " << r.accel_normalised_rms << ", gyro holds "
       << r.gyro_normalised_rms << ", runs " << r.run_normalised_rms << "; 1 = the noise)\n"
       << "  sigmas scaled by the measured residual: accel holds x" << r.accel_sigma_factor
       << ", gyro holds x" << r.gyro_sigma_factor << ", runs x" << r.run_sigma_factor << "\n"
       << "  solver: " << r.solver_report << "\n"
       << "  " << r.conditioning.describe();
}

// What the service did, in the order it did it.
void printOutcome(std::ostream& info, const std::string& label, const std::string& dlabel,
                  const calib::CalibrationOutcome& c) {
  const bool navigation = c.method == calib::ServiceMethod::kNavigation;
  if (c.direct) printDirect(info, navigation ? dlabel : label, *c.direct, !navigation);
  for (const std::string& n : c.notes) info << n << "\n";
  if (c.refined) printIndirect(info, "navigation-based calibration of " + label, *c.refined);
  for (const calib::TableParamDecision& d : c.table) {
    if (!d.estimated && d.reason.rfind("held at zero: the direct", 0) != 0) continue;
    info << "  " << d.name << ": " << d.reason << "\n";
  }
  info << c.sigma_check.describe();
}

calib::ServiceMethod serviceMethod(const std::string& method) {
  if (method == "direct") return calib::ServiceMethod::kDirect;
  if (method == "indirect") return calib::ServiceMethod::kNavigation;
  return calib::ServiceMethod::kAuto;
}

// Every table-based method through the one calibration service
// (calib/service/calibration_service.h). direct: the direct plan's recording when it is another
// recording than src.
void runService(const CalibrateOptions& o, const ResolvedRecording& src,
                const ResolvedRecording* direct) {
  std::ostream& info = o.json ? std::cerr : std::cout;
  const io::CalibrationView view(src.recording);
  std::optional<io::CalibrationView> dview;
  calib::CalibrationRequest rq;
  rq.recording = view.view();
  rq.method = serviceMethod(o.method);
  if (direct) {
    dview.emplace(direct->recording);
    rq.direct = dview->view();
  }
  if (!o.start.empty()) {
    const io::CoefficientFileResult s = io::readCoefficientFile(o.start);
    if (!s.status.ok) throw CommandFailed(s.status.message);
    rq.start = s.value;
    info << "start values: " << o.start << "\n";
  }
  if (!o.table_errors.empty()) {
    rq.known_table_errors = knownTableErrors(o);
    info << "table errors known beforehand: " << o.table_errors
         << " (every method takes them; the navigation-based calibration holds the "
            "nonorthogonality)\n";
  }
  refuseInconsistentTime(src.label, rq.recording);
  if (rq.direct) refuseInconsistentTime(direct->label, *rq.direct);
  calib::ServiceOptions so;
  so.checks = checksOf(o);
  // The jackknife of the sigmas (issue 26), linearised: 0.06 s more on the independent
  // writer's 65-unit two-axis recording, 0.3 s on its 111-unit three-axis one (measured;
  // docs/calibration.md): on by default, --no-sigma-check turns it off.
  so.sigma_check.enabled = o.sigma_check;
  const calib::CalibrationOutcome c = calib::calibrateRecording(rq, so);
  const std::string dlabel = direct ? direct->label : src.label;
  const std::string label = direct ? src.label + " + " + dlabel : src.label;
  info << "method: " << c.why_method << "\n";
  if (!c.status.HasResult()) throw CommandFailed(label + ": " + c.status.message);
  printOutcome(info, label, dlabel, c);
  refuseIfUnusable(c.status, label, src.label);
  emit(o, src, c.coefficients, calibrationJson(c), rq.recording.geometry,
       calib::gyroReferenced(c.method) ? TruthFrame::kGyroReferenced : TruthFrame::kAsIs);
}

void runScalarMethod(const CalibrateOptions& o, const ResolvedRecording& src) {
  std::ostream& info = o.json ? std::cerr : std::cout;
  const io::Recording& rec = src.recording;
  calib::RawImuData raw;
  double t_prev = nav::firstIntervalStart(rec.imu);
  for (const nav::ImuSample& s : rec.imu) {
    const double dt = s.t - t_prev;
    t_prev = s.t;
    raw.t.push_back(s.t - 0.5 * dt);
    raw.accel.push_back(s.dvel / dt);
    raw.gyro.push_back(s.dtheta / dt);
  }
  calib::ScalarCalibrationOptions so;
  so.gravity_mps2 = nav::siteGravity(rec.site());
  so.latitude_rad = rec.site().latitude_rad;
  so.gyro_scale_guess = 1.0;
  const calib::ScalarCalibrationResult r = calib::scalarCalibrate(raw, so, true);
  if (!r.status.ok) throw scalarRefusal(src.label, r.status);
  info << "scalar calibration of " << src.label << ": " << r.spans.size()
       << " static spans, |a|-g RMS " << r.accel_rms_before << " -> " << r.accel_rms_after
       << " m/s^2\n";
  for (const std::string& n : r.notes) info << "  note: " << n << "\n";
  emit(o, src, r.report, nullptr, io::geometryOf(rec), TruthFrame::kAsIs);
}

// True when two RUN_OR_DIR arguments hold the same recording (a directory and the run stored
// from it included): the same IMU samples and encoder samples.
bool sameRecording(const io::Recording& a, const io::Recording& b) {
  if (a.imu.size() != b.imu.size() || a.table.size() != b.table.size()) return false;
  for (std::size_t k = 0; k < a.imu.size(); ++k) {
    if (a.imu[k].t != b.imu[k].t || a.imu[k].dtheta != b.imu[k].dtheta ||
        a.imu[k].dvel != b.imu[k].dvel) {
      return false;
    }
  }
  for (std::size_t k = 0; k < a.table.size(); ++k) {
    if (a.table[k].t != b.table[k].t || a.table[k].angles_deg != b.table[k].angles_deg) {
      return false;
    }
  }
  return true;
}

void runCalibrate(const CalibrateOptions& o) {
  if (o.format != "imubench") {
    if (o.store_result) {
      throw CommandFailed("--store-result needs a run id, not a --format " + o.format + " file", 2);
    }
    runCalibrateReal(o);
    return;
  }
  const ResolvedRecording src = loadRunOrDir(o.dir, o.db);
  checkStoreResult(o, src);
  if (o.method == "scalar") return runScalarMethod(o, src);
  if (src.recording.table.empty()) {
    // No table angles (a logger's file, `imubench import-csv`): the scalar calibration is the
    // one method that needs none.
    if (!o.method.empty() || !o.direct_dir.empty()) {
      throw CommandFailed(src.label + ": the recording has no table angles: only --method scalar",
                          2);
    }
    (o.json ? std::cerr : std::cout)
        << "method: scalar: the recording has no table angles (the IMU was not on a table)\n";
    return runScalarMethod(o, src);
  }
  if (o.direct_dir.empty()) return runService(o, src, nullptr);
  const ResolvedRecording direct = loadRunOrDir(o.direct_dir, o.db);
  if (sameRecording(src.recording, direct.recording)) {
    std::ostream& info = o.json ? std::cerr : std::cout;
    info << "--direct names the recording itself: its data are used once\n";
    return runService(o, src, nullptr);
  }
  runService(o, src, &direct);
}

}  // namespace

void addCalibrateCommand(CLI::App& app) {
  auto opt = std::make_shared<CalibrateOptions>();
  CLI::App* sub = app.add_subcommand("calibrate", "Calibrate an IMU from a recording");
  sub->add_option("dir", opt->dir,
                  "Recording directory (imubench-csv/1) or run id (N or run:N, see --db); with "
                  "--format the recording file")
      ->required();
  sub->add_option("--method", opt->method,
                  "direct | indirect (the pipeline: direct, navigation-based refinement, "
                  "nonorthogonality pass) | scalar (default and only choice with --format "
                  "imutk/imucal); default: what the recording supports")
      ->check(CLI::IsMember({"direct", "indirect", "scalar"}));
  sub->add_flag("--json", opt->json, "Print the interchange coefficient JSON");
  sub->add_flag("!--no-sigma-check", opt->sigma_check,
                "Skip the leave-one-out (jackknife) check of the printed sigmas (on by default: "
                "one linearised resample per hold and run, well under a second)");
  sub->add_option("--out", opt->out, "Write the coefficient JSON to this file");
  sub->add_option("--start", opt->start,
                  "indirect: start values from this coefficient file instead of the direct "
                  "calibration of the same recording");
  sub->add_option("--truth", opt->truth,
                  "Compare the estimate with this truth file (simulated bench): per parameter "
                  "error against the targets (3 arcsec, 10 ppm, biases 2 sigma), the truth put "
                  "into the frame the method refers to");
  sub->add_option("--gyro-range", opt->gyro_range_dps,
                  "IMU gyro range, deg/s: samples at it are clipped and the recording is refused")
      ->check(CLI::PositiveNumber);
  sub->add_option("--accel-range", opt->accel_range_g,
                  "IMU accelerometer range, g: samples at it are clipped and the recording is "
                  "refused")
      ->check(CLI::PositiveNumber);
  sub->add_option("--direct", opt->direct_dir,
                  "indirect: the direct plan's recording of the same device and table; runs "
                  "the full pipeline (direct, refinement over both, nonorthogonality pass); "
                  "a directory or a run id");
  sub->add_option("--table-errors", opt->table_errors,
                  "Table errors known beforehand (the \"table\" section of a coefficient or "
                  "truth file: the table's certification data) for every method");
  addStoreOption(*sub, &opt->db);
  sub->add_flag("--store-result", opt->store_result,
                "When DIR is a run id: store the coefficient JSON as a result (kind "
                "\"coefficients\") of that run, with its IMU serial and mean temperature");
  sub->add_option("--format", opt->format,
                  "imubench (recording directory, default) | imutk (imu_tk text pair: "
                  "accelerometer file + --gyro) | imucal (imucal Ferraris CSV) | imu-calib "
                  "(alias mikov; imu-calib six-column log ax ay az wx wy wz, SI, no time column)")
      ->check(CLI::IsMember({"imubench", "imutk", "imucal", "imu-calib", "mikov"}));
  sub->add_option("--gyro", opt->gyro_file, "imutk: the gyro file of the pair");
  sub->add_option("--rate", opt->rate_hz,
                  "imucal/mikov: sampling rate, Hz (default 102.4 imucal, 100 mikov)")
      ->each([opt](const std::string&) { opt->rate_hz_given = true; });
  sub->add_option("--gravity", opt->gravity, "scalar on --format: local gravity, m/s^2");
  sub->add_option("--latitude", opt->latitude_deg,
                  "scalar on --format: site latitude, deg (WGS-84 normal gravity)");
  sub->add_option("--height", opt->height_m, "scalar on --format: site height, m (default 0)");
  sub->callback([opt] { runCalibrate(*opt); });
}

}  // namespace imubench::tools
