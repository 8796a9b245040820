// imubench thermal fit RUN_OR_DIR... [--order auto|N] [--t-ref DEGC] --out comp.json
//                                    [--csv comp.csv] [--method joint|points]
//                                    [--max-span DEGC] [--refinements N] [--report DIR]
// Each recording (imubench-csv/1 directory with IMU temperatures, from the daemon or written
// elsewhere) gives the direct calibration's rows: every static position and rate run.
//   joint (default): every row at its own IMU temperature and rate, all coefficients' polynomials
//     fitted through the sensor equation at once (calib::fitThermalJoint): a continuous ramp's
//     rows are as sharp as a soak point's, and on soak plans it is at least as accurate as the
//     per-point fit (bench/calibration/bench_thermal.cpp);
//   points: the recording split into temperature points at its soak segments, at each
//     repetition of a continuous-ramp plan ("up/rep03/..." labels) or into windows spanning at
//     most --max-span degC (calib/thermal/thermal_fit.h), each calibrated directly, the points
//     fitted, then re-made through that fit --refinements times (calib::fitThermalRuns).
// Both write an imubench-thermal/1 file; --report DIR also DIR/report.html (io/thermal_report.h):
// a plot per coefficient against temperature and the calibrated range flagged.
// Table errors (constant over temperature): joint estimates every one the motion makes
//   observable beside the polynomials (the others held at zero, the reason printed);
//   --table-errors FILE holds them at the "table" section of a coefficient/truth file (as
//   `calibrate --table-errors`; a file of zeros: the table taken as perfect). The joint fit
//   prints them with sigmas and adds a "table" section (coefficient-file shape, with "sigma" and
//   "observable") to the imubench-thermal/1 file; --method points takes them as given.
// Refusals (exit 1, naming the file): a recording without temperatures, a single temperature
// point, recordings of different IMU serials. The gate (exit 3, nothing written, the findings
// and the `imubench explain` hint): the joint fit unusable (calib/thermal/thermal_fit.h: a triad's
// normalised residual far above the noise floor, a coefficient or table error not determined,
// implausible values).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "calib/service/calibration_service.h"
#include "calib/thermal/thermal_fit.h"
#include "io/recording.h"
#include "io/sim_recording.h"
#include "io/thermal_file.h"
#include "io/thermal_report.h"
#include "io/truth_file.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

struct ThermalFitCliOptions {
  std::vector<std::string> runs;
  std::string order = "auto";
  double t_ref_c = 20.0;
  std::string out;
  std::string csv;
  std::string report;  // directory of report.html; empty: none
  std::string db;      // run store for run ids
  double max_span_c = calib::ThermalPointOptions{}.max_point_span_c;
  int refinements = calib::ThermalRunsFitOptions{}.refinements;
  std::string method = "joint";
  std::string table_errors;  // coefficient/truth file whose "table" is held; empty: estimate
};

// A recording directory or a run of the store (tools/cli_store.h RUN_OR_DIR).
io::Recording readRunOrFail(const std::string& arg, const std::string& db) {
  return loadRunOrDir(arg, db).recording;
}

int parseOrder(const std::string& s) {
  if (s == "auto") return -1;
  if (s.size() == 1 && s[0] >= '0' && s[0] <= '4') return s[0] - '0';
  throw CommandFailed("--order: expected auto or 0..4, got '" + s + "'", 2);
}

void printFit(const calib::ThermalFitResult& r) {
  std::cout << "temperature range " << r.coefficients.t_min_c << " .. " << r.coefficients.t_max_c
            << " degC, " << r.distinct_temperatures << " distinct temperatures"
            << (r.hysteresis_candidate ? ", heating and cooling" : "") << "\n";
  std::size_t i = 0;
  for (const bool accel : {true, false}) {
    const auto& t = accel ? r.coefficients.accel : r.coefficients.gyro;
    for (const auto& c : t) {
      const calib::ThermalCoefficientFit& f = r.fits[i++];
      std::cout << std::left << std::setw(24) << f.name << " order " << c.order
                << (c.hysteresis ? " +dT/dt" : "       ") << "  c0 " << std::setprecision(9)
                << c.poly[0] << "  chi2/n " << std::setprecision(3) << f.chi2 / f.points << "\n";
    }
  }
}

// Median |dT/dt| (degC/s) of the samples heating or cooling faster than min_rate: where the
// report draws the heating and cooling branches. 0 when every sample is soaked.
double typicalTemperatureRate(const std::vector<calib::ThermalRun>& runs, double min_rate) {
  std::vector<double> r;
  for (const calib::ThermalRun& run : runs) {
    for (const double v : calib::temperatureRates(run.input.imu)) {
      if (std::abs(v) > min_rate) r.push_back(std::abs(v));
    }
  }
  if (r.empty()) return 0.0;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return r[r.size() / 2];
}

void writeReport(const ThermalFitCliOptions& o, const std::vector<calib::ThermalRun>& runs,
                 const calib::ThermalRunsFitResult& fit) {
  io::ThermalReportOptions ro;
  for (const auto& d : o.runs) ro.title += (ro.title.empty() ? "" : ", ") + d;
  ro.method = o.method;
  ro.min_rate = calib::ThermalFitOptions{}.min_hysteresis_rate;
  ro.typical_rate = typicalTemperatureRate(runs, ro.min_rate);
  if (auto st = io::writeThermalReport(o.report, fit, ro); !st.ok) {
    throw CommandFailed("--report: " + st.message);
  }
}

constexpr double kArcsec = kPi / (180.0 * 3600.0);

// The table errors of the fit: value and sigma in arcsec, or held and why (the notes).
void printTable(const calib::ThermalRunsFitResult& fit,
                const std::vector<calib::TableParamDecision>& table) {
  std::cout << "table errors (constant over temperature):\n";
  const calib::CoefficientReport& t = fit.table;
  for (const calib::TableParamDecision& d : table) {
    const double v = calib::flatValue(t.values, d.name).value_or(0.0) / kArcsec;
    const auto it = t.uncertainty.find(d.name);
    std::cout << "  " << std::left << std::setw(34) << d.name << std::right << std::fixed
              << std::setprecision(2) << std::setw(9) << v << " arcsec";
    if (d.estimated && it != t.uncertainty.end() && it->second.sigma) {
      std::cout << "  sigma " << *it->second.sigma / kArcsec << " arcsec\n";
    } else {
      std::cout << "  held: " << d.reason << "\n";
    }
    std::cout.unsetf(std::ios::fixed);
  }
  for (const std::string& n : fit.notes) {
    if (n.rfind("table.", 0) != 0) std::cout << "note: " << n << "\n";
  }
  if (fit.accel_normalised_rms > 0.0 || fit.gyro_normalised_rms > 0.0) {
    std::cout << std::setprecision(3) << "normalised residual RMS: accel "
              << fit.accel_normalised_rms << ", gyro " << fit.gyro_normalised_rms
              << " (1 = the noise floor)\n";
  }
}

// The imubench-thermal/1 file with the fit's table errors as an extra "table" section (the
// coefficient file's shape; readers of the thermal form ignore it).
void writeThermalWithTable(const std::string& path, const io::ThermalFile& file,
                           const calib::ThermalRunsFitResult& fit) {
  nlohmann::json j = io::toJson(file);
  const nlohmann::json t = calib::toJson(fit.table);
  if (t.contains("table")) j["table"] = t["table"];
  if (auto st = io::writeJsonFile(path, j); !st.ok) throw CommandFailed(st.message);
}

void runThermalFit(const ThermalFitCliOptions& o) {
  std::error_code ec;
  if (!o.report.empty() && std::filesystem::exists(o.report, ec) &&
      !std::filesystem::is_directory(o.report, ec)) {
    throw CommandFailed("--report " + o.report + ": exists and is not a directory");
  }
  calib::ThermalServiceOptions so;
  so.fit.order = parseOrder(o.order);
  so.fit.t_ref_c = o.t_ref_c;
  so.points.points.max_point_span_c = o.max_span_c;
  so.points.refinements = o.refinements;
  calib::ThermalCalibrationRequest rq;
  rq.method = o.method == "joint" ? calib::ThermalMethod::kJoint : calib::ThermalMethod::kPoints;
  std::string serial, serial_dir;
  for (const std::string& dir : o.runs) {
    const io::Recording rec = readRunOrFail(dir, o.db);
    if (!serial_dir.empty() && rec.imu_serial != serial) {
      throw CommandFailed(dir + ": IMU serial '" + rec.imu_serial + "' differs from '" + serial +
                          "' of " + serial_dir + ": a thermal model is one IMU's");
    }
    serial = rec.imu_serial;
    serial_dir = dir;
    rq.runs.push_back({io::CalibrationView(rec).owned(), dir});
  }
  if (!o.table_errors.empty()) rq.known_table_errors = loadTruthOrFail(o.table_errors).table;
  const calib::ThermalCalibrationOutcome c = calib::calibrateThermal(rq, so);
  const calib::ThermalRunsFitResult& fit = c.fit;
  const bool joint = c.method == calib::ThermalMethod::kJoint;
  if (!c.status.HasResult()) {
    std::string files;
    for (const auto& d : o.runs) files += (files.empty() ? "" : ", ") + d;
    // A run's error names its recording; a fit's (e.g. a single temperature) names all.
    throw CommandFailed(fit.fit.status.HasResult() ? c.status.message
                                                   : files + ": " + c.status.message);
  }
  if (joint) std::cout << "joint fit of every static and rate run: " << fit.passes << " sweeps\n";
  for (const auto& pt : fit.points) {
    std::cout << pt.source << ": " << std::setprecision(4) << pt.temp_c << " degC, "
              << pt.temp_rate * 60.0 << " degC/min, span " << pt.temp_span_c << " degC\n";
  }
  const calib::ThermalFitResult& r = fit.fit;
  printFit(r);
  printTable(fit, c.table);
  std::string dirs;
  for (const auto& d : o.runs) dirs += (dirs.empty() ? "" : " ") + d;
  refuseIfUnusable(c.status, "thermal fit of " + dirs, o.runs.front());
  const io::ThermalFile file{serial, r.coefficients};
  if (joint) {
    writeThermalWithTable(o.out, file, fit);
  } else if (auto st = io::writeThermalFile(o.out, file); !st.ok) {
    throw CommandFailed(st.message);
  }
  if (!o.csv.empty()) {
    if (auto st = io::writeThermalCsv(o.csv, file); !st.ok) throw CommandFailed(st.message);
  }
  if (!o.report.empty()) writeReport(o, rq.runs, fit);
  std::cout << "wrote " << o.out << (o.csv.empty() ? "" : " and " + o.csv)
            << (o.report.empty() ? "" : " and " + o.report + "/report.html") << "\n";
}

}  // namespace

void addThermalCommand(CLI::App& app) {
  CLI::App* thermal = app.add_subcommand("thermal", "thermal calibration over temperature");
  thermal->require_subcommand(1);
  auto opt = std::make_shared<ThermalFitCliOptions>();
  CLI::App* fit = thermal->add_subcommand(
      "fit", "fit every coefficient over temperature from recordings at several temperatures");
  fit->add_option(
         "runs", opt->runs,
         "recordings at several temperatures: imubench-csv/1 directories or run ids (N, run:N)")
      ->required();
  fit->add_option("--order", opt->order, "polynomial order: auto (BIC per coefficient) or 0..4")
      ->capture_default_str();
  fit->add_option("--t-ref", opt->t_ref_c, "polynomial origin, degC")->capture_default_str();
  fit->add_option("--out", opt->out, "imubench-thermal/1 JSON file to write")->required();
  fit->add_option("--csv", opt->csv, "also write the CSV form");
  fit->add_option("--report", opt->report,
                  "also write DIR/report.html: each coefficient against temperature (points, "
                  "fit, band, heating/cooling branches) and the calibrated range flagged");
  fit->add_option("--method", opt->method,
                  "joint: every static and rate run at its own temperature (default); points: "
                  "a direct calibration per temperature point, polynomials through the points")
      ->capture_default_str()
      ->check(CLI::IsMember({"joint", "points"}));
  fit->add_option("--max-span", opt->max_span_c,
                  "--method points: widest temperature range of one point of a ramp without "
                  "soaks or repetition labels, degC")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  fit->add_option("--refinements", opt->refinements,
                  "--method points: passes re-making the points through the previous fit "
                  "(continuous ramps)")
      ->capture_default_str()
      ->check(CLI::Range(0, 10));
  fit->add_option("--table-errors", opt->table_errors,
                  "hold the table errors at the \"table\" section of this coefficient/truth file "
                  "(zeros: a perfect table) instead of estimating the observable ones");
  addStoreOption(*fit, &opt->db);
  fit->callback([opt] { runThermalFit(*opt); });
}

}  // namespace imubench::tools
