// Shared pieces of the `imubench` command line.
//
// How subcommands are added (the pattern every cli_*.cpp follows):
//   - one file per subcommand (or family), tools/cli_<name>.cpp, exposing
//       void add<Name>Command(CLI::App& app);
//     declared below and called once from tools/imubench.cpp's main();
//   - add<Name>Command creates the subcommand, binds its options into a
//     std::shared_ptr<Options> captured by the callback, and sets
//       sub->callback([opt] { run<Name>(*opt); });
//   - the run function prints results on stdout, problems on stderr, and on failure throws
//     CommandFailed (exit code 1 for bad input files / failed work; CLI11 parse errors exit 2).
//     main() turns every exception into a message and an exit code: nothing escapes.
//   - the work itself lives in the libraries (plans/, calib/, nav/, daemon/); cli files only
//     translate options, call them and format results.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "calib/bench_truth.h"
#include "calib/fit_quality.h"
#include "calib/noise.h"
#include "calib/recording_view.h"
#include "calib/scalar/scalar_calibration.h"
#include "calib/table_model.h"
#include "calib/truth_comparison.h"
#include "io/import_real.h"
#include "nav/earth.h"
#include "tools/cli11.h"

namespace imubench::tools {

// Registration functions, one per file.
void addRunCommand(CLI::App& app);       // cli_run.cpp
void addSimulateCommand(CLI::App& app);  // cli_simulate.cpp
void addPlanCommand(CLI::App& app);      // cli_plan.cpp
void addNavCommand(CLI::App& app);       // cli_nav.cpp
// Calibration engineer's subcommands (declared here; registered in main() once their
// sources are in tools/CMakeLists.txt).
void addCalibrateCommand(CLI::App& app);   // cli_calibrate.cpp
void addExperimentCommand(CLI::App& app);  // cli_experiment.cpp
void addObserveCommand(CLI::App& app);     // cli_observe.cpp (`imubench plan observe`)
void addExplainCommand(CLI::App& app);     // cli_explain.cpp (model-discrepancy analysis)
// The run store: `runs`, `export`, `import` (cli_runs.cpp; --db and run ids in cli_store.h).
void addStoreCommands(CLI::App& app);
// Operator's commands to imubenchd over its control socket: start, pause, resume, abort, stop,
// status, results, watch.
void addControlCommands(CLI::App& app);      // cli_control.cpp
void addResultsCommand(CLI::App& app);       // cli_results.cpp
void addThermalCommand(CLI::App& app);       // cli_thermal.cpp (`thermal fit`)
void addApplyCommand(CLI::App& app);         // cli_apply.cpp
void addImportCsvCommand(CLI::App& app);     // cli_import_csv.cpp (`import-csv`)
void addExportCoeffsCommand(CLI::App& app);  // cli_export_coeffs.cpp (`export-coeffs`)
void addCertificateCommand(CLI::App& app);   // cli_certificate.cpp (`certificate`)

// "2024-05-01T12:00:00Z"; "-" for a time that does not fit.
std::string utcTime(double unix_s);

// A subcommand failed; the message has already been printed (or is printed by main).
class CommandFailed : public std::runtime_error {
 public:
  explicit CommandFailed(const std::string& message, int exit_code = 1)
      : std::runtime_error(message), exit_code_(exit_code) {}
  int exitCode() const { return exit_code_; }

 private:
  int exit_code_;
};

// Site options shared by simulate and run.
struct SiteOptions {
  double latitude_deg = 55.75;  // default lab site: a mid-latitude (Moscow) bench
  double height_m = 150.0;
  std::optional<double> gravity_mps2;
  nav::Site site() const;
};
void addSiteOptions(CLI::App& sub, SiteOptions* opt);

// Noise model by name: none, nav-grade, nav-grade-drift, tactical, consumer.
const char* noiseNames();  // "none|nav-grade|nav-grade-drift|tactical|consumer"

// The simulation options shared by `run` and `simulate`: --rate HZ (IMU output rate),
// --seed N (noise seed), --noise NAME (one of noiseNames()).
struct SimulationOptions {
  double rate_hz = 200.0;
  std::uint64_t seed = 1;
  std::string noise = "nav-grade";
};
void addSimulationOptions(CLI::App& sub, SimulationOptions* opt);
std::optional<calib::NoiseModel> noiseByName(const std::string& name);

// The bundled plan library: <source dir>/plans/library when built from a checkout, else the
// installed data dir. Empty string when neither holds `file`.
std::string bundledPlanPath(const std::string& file);

// The embedded default bench truth: navigation-grade sensor errors and table errors of tens
// of arcseconds (JSON text in cli_common.cpp, so it reads like a truth file).
calib::BenchTruth defaultTruth();
const char* defaultTruthJson();

// Reads --truth FILE (throws CommandFailed with the file error).
calib::BenchTruth loadTruthOrFail(const std::string& path);

// The truth in the gyro-referenced platform frame the navigation-based coefficients refer to
// (calib::toGyroReferenced: mounting absorbed, outer zero in the tilt) for table geometry g.
calib::BenchTruth gyroReferencedTruth(const calib::BenchTruth& truth,
                                      const calib::TableGeometry& g);
// One line per compared parameter: its error and limit in the parameter's unit, and ok,
// OUTSIDE or "held (not judged)".
void printComparisonRows(const calib::TruthComparison& c);

// A third-party recording without table angles (--format imutk|imucal|imu-calib;
// mikov is imu-calib's old name), as `calibrate`
// and `explain` read it: its readings and the scalar calibration options it implies (imu_tk's
// long initial static and unsigned-count rails; gravity from --gravity, else from --latitude
// and --height, else the options' default).
struct RealRecordingOptions {
  std::string format;             // imutk | imucal | imu-calib (alias mikov)
  std::string path;               // the file (imutk: the accelerometer file)
  std::string gyro_file;          // imutk: the gyro file of the pair
  std::optional<double> rate_hz;  // imucal, mikov: sampling rate (default: the source's)
  std::optional<double> gravity;  // m/s^2
  std::optional<double> latitude_deg;
  double height_m = 0.0;
  // --gyro-range DPS / --accel-range G: the IMU's ranges, checked on the calibrated readings
  // (ScalarCalibrationOptions::gyro_range_radps) whatever the format's reading unit.
  std::optional<double> gyro_range_dps;
  std::optional<double> accel_range_g;
};
struct RealRecording {
  io::RealImport import;
  calib::ScalarCalibrationOptions scalar;
  bool accel_si = false;  // accelerometer readings already in m/s^2
};
// Throws CommandFailed: the reader's error (exit 1), a missing --gyro or invalid options (2).
RealRecording readRealRecording(const RealRecordingOptions& o);

// Exit code of a refusal whose result would be unusable (calibrate and explain alike).
inline constexpr int kExitResultUnusable = 3;
// The scalar calibration's gyro scales against the reading unit's nominal (deg/s, rad/s):
// a factor off means the time axis (--rate, or the format's default rate) is not the
// recording's. Throws CommandFailed(kExitResultUnusable) naming the rate; nothing for counts.
void refuseInconsistentRate(const RealRecordingOptions& o, const RealRecording& real,
                            const calib::TriadModel& gyro);
// The data of a table recording against its time axis (calib/recording_checks.h): the gyro's
// integrated rotation against the table's, or the static gyro norm against the Earth rate.
// Throws CommandFailed(kExitResultUnusable) with label and why.
void refuseInconsistentTime(const std::string& label, const calib::RecordingView& view);
// A fit the gate refuses (calib/fit_quality.h kUnusable): throws
// CommandFailed(kExitResultUnusable) with what, the findings, the largest residuals, that
// nothing was written and what to do next: the `imubench explain EXPLAIN_TARGET` hint when the
// residuals exceed the noise (status.misfit), else that the findings are the recording's
// (undetermined or implausible coefficients). Otherwise nothing.
void refuseIfUnusable(const calib::FitStatus& status, const std::string& what,
                      const std::string& explain_target);

}  // namespace imubench::tools
