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
// angles: scalar calibration only) and runs one calibration method. Without --method it
// picks what the recording supports and says why: holds and rotation runs -> the whole
// pipeline on the one recording (the same answer as --method indirect --direct DIR); holds
// only -> direct. The methods:
//   direct    the table-based direct calibration (calib/direct_calibration.h);
//   indirect  the navigation-based refinement (calib/indirect_calibration.h), started from the
//             direct calibration of the same recording (or --start FILE, a coefficient file);
//             with --direct DIRECT_DIR (the direct plan's recording of the same device on the
//             same table) the production pipeline of calib/bench_calibration.h: direct
//             calibration of DIRECT_DIR, refinement over both recordings, second pass when the
//             table's axes are nonorthogonal;
//   scalar    the table-free field calibration (calib/scalar_calibration.h).
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

#include "calib/bench_calibration.h"
#include "calib/direct_calibration.h"
#include "calib/fit_quality.h"
#include "calib/indirect_calibration.h"
#include "calib/scalar_calibration.h"
#include "calib/scalar_consistency.h"
#include "calib/segment_check.h"
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
  std::string method;  // empty: indirect for imubench recordings, scalar for the others
  std::string format = "imubench";
  std::string gyro_file;                      // imutk: the gyro file of the pair
  double rate_hz = io::kImucalExampleRateHz;  // imucal: sampling rate
  bool rate_hz_given = false;                 // --rate on the command line (mikov: 100 Hz)
  std::optional<double> gravity;              // m/s^2; else from --latitude/--height
  std::optional<double> latitude_deg;
  double height_m = 0.0;
  bool json = false;
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
constexpr int kExitUnusable = 3;

// A scalar calibration that did not give a result: the data cannot determine the coefficients
// (too few or too similar poses, readings that contradict gravity) is "result unusable" (exit
// 3); malformed data (NaN, gaps, time going back) is a plain error (exit 1).
CommandFailed scalarRefusal(const std::string& label, const calib::RecordingCheck& status) {
  const bool unusable = status.code == calib::RecordingStatusCode::kTooFewStatics ||
                        status.code == calib::RecordingStatusCode::kTooShortStatic;
  return CommandFailed(label + ": scalar calibration: " + status.message,
                       unusable ? kExitUnusable : 1);
}

// Throws CommandFailed(kExitUnusable) with the findings when the result is unusable.
void refuseIfUnusable(const calib::FitStatus& s, const std::string& what, const std::string& dir) {
  if (s.code != calib::FitStatusCode::kUnusable) return;
  std::string m = what + ": " + s.message;
  for (const std::string& r : s.reasons) m += "\n  finding: " + r;
  for (const std::string& r : s.largest_residuals) m += "\n  large residual: " + r;
  m += "\n  nothing written; `imubench explain " + dir +
       "` names the effect the model lacks (result unusable, exit 3)";
  throw CommandFailed(m, kExitUnusable);
}

// --table-errors: the table section of a coefficient/truth file (zero when not given).
calib::TableErrors knownTableErrors(const CalibrateOptions& o) {
  if (o.table_errors.empty()) return {};
  return loadTruthOrFail(o.table_errors).table;
}

using io::geometryOf;
using io::tableSamples;

calib::DirectCalibrationResult runDirect(const io::Recording& rec,
                                         const std::vector<calib::TableSample>& table,
                                         const calib::IncrementCheckOptions& checks,
                                         const calib::TableErrors& known = {}) {
  calib::DirectCalibrationInput in;
  in.geometry = geometryOf(rec);
  in.site = rec.site();
  in.imu = rec.imu;
  in.table = table;
  in.segments = rec.segments;
  calib::DirectCalibrationOptions o;
  o.checks = checks;
  o.known_table_errors = known;
  return calib::calibrateDirect(in, o);
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
  if (o.json) {
    nlohmann::json j = calib::toJson(r.report);
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
    const Status s = io::writeCoefficientFile(o.out, r.report);
    if (!s.ok) throw CommandFailed(s.message);
  }
}

calib::IncrementCheckOptions checksOf(const CalibrateOptions& o) {
  calib::IncrementCheckOptions c;
  if (o.gyro_range_dps) c.gyro_range_radps = *o.gyro_range_dps * kDegToRad;
  if (o.accel_range_g) c.accel_range_mps2 = *o.accel_range_g * 9.80665;
  return c;
}

nlohmann::json indirectExtra(const calib::CalibrationResult& r) {
  nlohmann::json extra;
  extra["method"] = "indirect";
  extra["conditioning"] = calib::toJson(r.conditioning);
  extra["rms_normalised_residual"] = r.rms_normalised_residual;
  return extra;
}

void printIndirect(std::ostream& info, const std::string& what, const calib::CalibrationResult& r) {
  for (const std::string& w : r.warnings) info << "  warning: " << w << "\n";
  info << what << ": " << r.outer_iterations << " outer iterations, normalised residual RMS "
       << r.rms_normalised_residual << "\n"
       << "  solver: " << r.solver_report << "\n"
       << "  " << r.conditioning.describe();
}

// The pipeline (calib/bench_calibration.h): direct calibration of the direct recording,
// refinement over it and the navigation recording, nonorthogonality pass. direct == nullptr:
// the one recording src holds both the direct positions and the navigation runs.
void runPipeline(const CalibrateOptions& o, const ResolvedRecording& src,
                 const std::vector<calib::TableSample>& table, const ResolvedRecording* direct) {
  std::ostream& info = o.json ? std::cerr : std::cout;
  const io::Recording& rec = src.recording;
  const io::Recording& drec = direct ? direct->recording : rec;
  const std::string& dlabel = direct ? direct->label : src.label;
  if (drec.table_kind != rec.table_kind) {
    throw CommandFailed(dlabel + " and " + src.label +
                        " were recorded on different table kinds: not the same table");
  }
  const std::vector<calib::TableSample> dtable = direct ? tableSamples(drec) : table;
  calib::BenchCalibrationInput in;
  in.direct.geometry = geometryOf(drec);
  in.direct.site = drec.site();
  in.direct.imu = drec.imu;
  in.direct.table = dtable;
  in.direct.segments = drec.segments;
  if (direct) in.navigation.push_back({rec.imu, table, rec.segments});
  calib::BenchCalibrationOptions bo;
  bo.direct.checks = bo.indirect.checks = checksOf(o);
  if (!o.table_errors.empty()) {
    bo.direct.known_table_errors = knownTableErrors(o);
    bo.indirect.estimate_nonorthogonality = false;
    info << "table errors known beforehand: " << o.table_errors
         << " (direct calibration takes them; the refinement holds the nonorthogonality)\n";
  }
  const calib::BenchCalibrationResult r = calib::calibrateBench(in, bo);
  const std::string label = direct ? src.label + " + " + dlabel : src.label;
  if (!r.status.HasResult()) throw CommandFailed(label + ": " + r.status.message);
  info << "direct calibration of " << dlabel << ": " << r.direct.statics_used << " statics, "
       << r.direct.rotations_used << " rotations\n";
  for (const std::string& n : r.direct.notes) {
    if (n.rfind("static segments joined", 0) == 0 || n.rfind("segments.csv", 0) == 0) {
      info << "  note: " << n << "\n";
    }
  }
  if (r.passes == 2) {
    info << "table axes nonorthogonal: direct calibration repeated with the estimated "
            "nonorthogonality, refinement repeated from it\n";
  }
  printIndirect(info, "navigation-based calibration of " + label, r.refined);
  refuseIfUnusable(r.status, label, src.label);
  nlohmann::json extra = indirectExtra(r.refined);
  extra["passes"] = r.passes;
  extra["method"] = "pipeline";
  emit(o, src, r.refined.coefficients, extra, in.direct.geometry, TruthFrame::kGyroReferenced);
}

// The method for a recording when none is given, with the reason printed.
std::string chooseMethod(const io::Recording& rec, const std::vector<calib::TableSample>& table,
                         std::ostream& info) {
  const calib::SegmentCheckResult c = calib::checkSegments(rec.table_kind, table, rec.segments);
  int holds = 0, runs = 0;
  for (const calib::Segment& s : c.segments) {
    if (!s.recording) continue;
    holds += s.kind == calib::SegmentKind::kStatic ? 1 : 0;
    runs += s.kind == calib::SegmentKind::kRotate ? 1 : 0;
  }
  const std::string counts = std::to_string(holds) + " holds and " + std::to_string(runs) +
                             " rotation runs" +
                             (rec.segments_from_file ? " (segments.csv)" : " (from the encoders)");
  if (runs > 0) {
    info << "method: the whole pipeline (direct calibration, navigation-based refinement, "
            "nonorthogonality pass) on this one recording: it holds "
         << counts << "\n";
    return "pipeline";
  }
  info << "method: direct: the recording holds " << counts
       << "; without rotation runs the navigation-based refinement has nothing to navigate\n";
  return "direct";
}

void runDirectMethod(const CalibrateOptions& o, const ResolvedRecording& src,
                     const std::vector<calib::TableSample>& table) {
  std::ostream& info = o.json ? std::cerr : std::cout;
  const io::Recording& rec = src.recording;
  const calib::DirectCalibrationResult r = runDirect(rec, table, checksOf(o), knownTableErrors(o));
  if (!r.status.HasResult())
    throw CommandFailed(src.label + ": direct calibration failed: " + r.status.message);
  info << "direct calibration of " << src.label << ": " << r.statics_used << " statics, "
       << r.rotations_used << " rotations, normalised residual RMS " << r.normalised_residual_rms
       << "\n";
  for (const std::string& n : r.notes) info << "  note: " << n << "\n";
  refuseIfUnusable(r.status, src.label + ": direct calibration", src.label);
  emit(o, src, r.report, nullptr, geometryOf(rec), TruthFrame::kAsIs);
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
  emit(o, src, r.report, nullptr, geometryOf(rec), TruthFrame::kAsIs);
}

// --method indirect --start FILE: the refinement alone from the given start values.
void runRefinementFrom(const CalibrateOptions& o, const ResolvedRecording& src,
                       const std::vector<calib::TableSample>& table) {
  std::ostream& info = o.json ? std::cerr : std::cout;
  const io::Recording& rec = src.recording;
  calib::IndirectInput in;
  in.site = rec.site();
  in.geometry = geometryOf(rec);
  in.imu = rec.imu;
  in.table = table;
  in.segments = rec.segments;
  const io::CoefficientFileResult s = io::readCoefficientFile(o.start);
  if (!s.status.ok) throw CommandFailed(s.status.message);
  in.start = s.value.values.sensors;
  in.start_uncertainty = s.value.uncertainty;
  in.start_base_tilt = s.value.values.table.base_tilt;
  calib::IndirectOptions io;
  io.checks = checksOf(o);
  if (!o.table_errors.empty()) {
    const calib::TableErrors known = knownTableErrors(o);
    in.start_base_tilt = known.base_tilt;
    in.start_nonorthogonality = known.nonorthogonality;
    io.estimate_nonorthogonality = false;
  }
  info << "start values: " << o.start << "\n";
  const calib::CalibrationResult r = calib::calibrateIndirect(in, io);
  if (!r.status.HasResult()) {
    for (const std::string& w : r.warnings) info << "  warning: " << w << "\n";
    throw CommandFailed(src.label + ": navigation-based calibration failed: " + r.status.message);
  }
  printIndirect(info, "navigation-based calibration of " + src.label, r);
  refuseIfUnusable(r.status, src.label, src.label);
  emit(o, src, r.coefficients, indirectExtra(r), in.geometry, TruthFrame::kGyroReferenced);
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
  const std::vector<calib::TableSample> table = tableSamples(src.recording);
  std::ostream& info = o.json ? std::cerr : std::cout;
  std::string method = o.method;
  if (method.empty()) {
    method = o.direct_dir.empty() ? chooseMethod(src.recording, table, info) : "indirect";
  }
  if (method == "direct") return runDirectMethod(o, src, table);
  if (method == "scalar") return runScalarMethod(o, src);
  if (method != "indirect" && method != "pipeline") {
    throw CommandFailed("unknown method '" + method + "'", 2);
  }
  if (!o.start.empty()) return runRefinementFrom(o, src, table);
  if (o.direct_dir.empty()) return runPipeline(o, src, table, nullptr);
  const ResolvedRecording direct = loadRunOrDir(o.direct_dir, o.db);
  if (sameRecording(src.recording, direct.recording)) {
    info << "--direct names the recording itself: its data are used once\n";
    return runPipeline(o, src, table, nullptr);
  }
  runPipeline(o, src, table, &direct);
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
                  "accelerometer file + --gyro) | imucal (imucal Ferraris CSV) | mikov "
                  "(imu-calib six-column log ax ay az wx wy wz, SI, no time column)")
      ->check(CLI::IsMember({"imubench", "imutk", "imucal", "mikov"}));
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
