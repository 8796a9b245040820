#include "tools/cli_common.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <vector>

#include "calib/indirect/indirect_calibration.h"
#include "calib/recording_checks.h"
#include "io/truth_file.h"

namespace imubench::tools {

// "2024-05-01T12:00:00Z"; "-" for a time that does not fit.
std::string utcTime(double unix_s) {
  if (!std::isfinite(unix_s)) return "-";
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  if (gmtime_r(&t, &tm) == nullptr) return "-";
  char buf[32];
  if (std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm) == 0) return "-";
  return buf;
}

nav::Site SiteOptions::site() const {
  nav::Site s;
  s.latitude_rad = latitude_deg * kDegToRad;
  s.height_m = height_m;
  s.gravity_mps2 = gravity_mps2;
  return s;
}

void addSiteOptions(CLI::App& sub, SiteOptions* opt) {
  sub.add_option("--site-lat", opt->latitude_deg, "site latitude, deg")
      ->check(CLI::Range(-89.0, 89.0))
      ->capture_default_str();
  sub.add_option("--site-height", opt->height_m, "site height, m")
      ->check(CLI::Range(-500.0, 9000.0))
      ->capture_default_str();
  sub.add_option("--site-gravity", opt->gravity_mps2,
                 "measured site gravity, m/s^2 (default: WGS-84 normal gravity)")
      ->check(CLI::Range(9.7, 9.9));
}

const char* noiseNames() {
  return calib::NoiseModel::names();
}

std::optional<calib::NoiseModel> noiseByName(const std::string& name) {
  return calib::NoiseModel::byName(name);
}

void addSimulationOptions(CLI::App& sub, SimulationOptions* opt) {
  std::vector<std::string> names;
  std::stringstream all(noiseNames());
  for (std::string n; std::getline(all, n, '|');) names.push_back(n);
  sub.add_option("--rate", opt->rate_hz, "IMU output rate, Hz")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  sub.add_option("--seed", opt->seed, "noise seed")->capture_default_str();
  sub.add_option("--noise", opt->noise, std::string("sensor noise: ") + noiseNames())
      ->check(CLI::IsMember(names))
      ->capture_default_str();
}

std::string bundledPlanPath(const std::string& file) {
  namespace fs = std::filesystem;
  const fs::path candidates[] = {
#ifdef IMUBENCH_SOURCE_DIR
      fs::path(IMUBENCH_SOURCE_DIR) / "plans" / "library" / file,
#endif
#ifdef IMUBENCH_DATA_DIR
      fs::path(IMUBENCH_DATA_DIR) / "plans" / file,
#endif
  };
  std::error_code ec;
  for (const auto& p : candidates) {
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  return {};
}

// Navigation-grade IMU (ring-laser/FOG class gyros, quartz-pendulum accelerometers) on a
// production two-axis table: accelerometer biases ~50-100 ug, scale errors ~100 ppm,
// misalignments ~10-40 arcsec; gyro biases ~0.01-0.03 deg/h, scale errors ~10-30 ppm; table
// errors tens of arcsec. Units SI (rad, rad/s, m/s^2).
const char* defaultTruthJson() {
  return R"({
  "accel": {
    "scale": [1.00012, 0.99991, 1.00007],
    "bias": [5.0e-4, -7.5e-4, 9.0e-4],
    "misalignment": {"xy": 9.7e-5, "xz": -6.3e-5, "yx": 1.45e-4, "yz": 4.8e-5, "zx": -1.21e-4, "zy": 7.3e-5}
  },
  "gyro": {
    "scale": [1.000021, 0.999985, 1.000030],
    "bias": [4.8e-8, -9.7e-8, 1.45e-7],
    "misalignment": {"xy": 4.8e-5, "xz": -2.9e-5, "yx": 7.8e-5, "yz": -5.3e-5, "zx": 3.4e-5, "zy": -6.8e-5}
  },
  "table": {
    "base_tilt": [9.7e-5, -7.3e-5],
    "nonorthogonality": [1.45e-4],
    "mounting": [1.94e-4, -1.21e-4],
    "encoder_zero": [4.8e-5, -9.7e-5]
  }
})";
}

calib::BenchTruth defaultTruth() {
  calib::BenchTruth truth;
  std::string why;
  const bool ok = calib::fromJson(nlohmann::json::parse(defaultTruthJson()), &truth, &why);
  if (!ok) throw std::logic_error("embedded default truth does not parse: " + why);  // our bug
  return truth;
}

calib::BenchTruth loadTruthOrFail(const std::string& path) {
  auto r = io::readTruthFile(path);
  if (!r.status.ok) throw CommandFailed(r.status.message);
  return r.value;
}

calib::BenchTruth gyroReferencedTruth(const calib::BenchTruth& truth,
                                      const calib::TableGeometry& g) {
  const calib::GyroReferencedTruth m = calib::toGyroReferenced(truth, g);
  calib::BenchTruth e;
  e.sensors = m.sensors;
  e.table.base_tilt = m.base_tilt;
  e.table.nonorthogonality = m.nonorthogonality;
  e.table_kind = g.kind;
  e.extra = truth.extra;  // extra effects do not depend on the frame: compared as written
  return e;
}

void printComparisonRows(const calib::TruthComparison& c) {
  for (const calib::ComparisonRow& r : c.rows) {
    std::printf("  %-34s error %+10.3f %-6s limit %8.3f  %s\n", r.name.c_str(), r.error_in_unit,
                r.unit.c_str(), r.limit_in_unit,
                !r.observable ? "held (not judged)" : (r.within ? "ok" : "OUTSIDE"));
  }
}

RealRecording readRealRecording(const RealRecordingOptions& o) {
  RealRecording r;
  calib::ScalarCalibrationOptions& so = r.scalar;
  if (o.format == "imutk") {
    if (o.gyro_file.empty()) throw CommandFailed("--format imutk needs --gyro FILE", 2);
    r.import = io::readImuTkPair(o.path, o.gyro_file);
    so.min_initial_static_s = 30.0;  // imu_tk records a long initial static for the gyro bias
    if (r.import.unsigned_counts) {  // 16-bit unsigned raw counts: the rails are saturation
      so.checks.accel_min = so.checks.gyro_min = 0.0;
      so.checks.accel_max = so.checks.gyro_max = 65535.0;
    }
  } else if (o.format == "imu-calib" || o.format == "mikov") {
    if (o.format == "mikov")
      std::cerr << "imubench: note: --format mikov is the old name of --format imu-calib\n";
    r.import = io::readSixColumnLog(o.path, o.rate_hz.value_or(io::kSixColumnLogRateHz));
    r.accel_si = true;
  } else {
    r.import = io::readImucalCsv(o.path, o.rate_hz.value_or(io::kImucalExampleRateHz));
    r.accel_si = true;
  }
  if (!r.import.status.ok) throw CommandFailed(r.import.status.message);
  if (o.latitude_deg) so.latitude_rad = *o.latitude_deg * kDegToRad;
  if (o.gravity) {
    so.gravity_mps2 = *o.gravity;
  } else if (o.latitude_deg) {
    so.gravity_mps2 = nav::normalGravity(*o.latitude_deg * kDegToRad, o.height_m);
  }
  if (o.gyro_range_dps) so.gyro_range_radps = *o.gyro_range_dps * kDegToRad;
  if (o.accel_range_g) so.accel_range_mps2 = *o.accel_range_g * 9.80665;
  std::string why;
  if (!so.IsValid(&why)) throw CommandFailed("options: " + why, 2);
  return r;
}

void refuseInconsistentRate(const RealRecordingOptions& o, const RealRecording& real,
                            const calib::TriadModel& gyro) {
  const std::optional<double> nominal = calib::gyroReadingsPerRadps(real.import.gyro_unit);
  const std::vector<double>& t = real.import.data.t;
  if (!nominal || t.size() < 2) return;
  char rate[80];
  std::snprintf(rate, sizeof(rate), o.rate_hz ? "--rate %g Hz" : "the default rate %g Hz",
                static_cast<double>(t.size() - 1) / (t.back() - t.front()));
  const calib::RateConsistency c = calib::checkRateConsistency(gyro, *nominal, rate);
  if (!c.status.ok) {
    throw CommandFailed(o.path + ": " + c.status.message + " (result unusable, exit 3)",
                        kExitResultUnusable);
  }
}

void refuseInconsistentTime(const std::string& label, const calib::RecordingView& view) {
  const calib::RateConsistency c = calib::checkRateConsistency(view);
  if (!c.status.ok) {
    throw CommandFailed(label + ": " + c.status.message + " (result unusable, exit 3)",
                        kExitResultUnusable);
  }
}

void refuseIfUnusable(const calib::FitStatus& status, const std::string& what,
                      const std::string& explain_target) {
  if (status.code != calib::FitStatusCode::kUnusable) return;
  std::string m = what + ": " + status.message;
  for (const std::string& r : status.reasons) m += "\n  finding: " + r;
  for (const std::string& r : status.largest_residuals) m += "\n  large residual: " + r;
  if (status.misfit) {
    m += "\n  nothing written; `imubench explain " + explain_target +
         "` names the effect the model lacks (result unusable, exit 3)";
  } else {
    // Residuals within the limit: no richer model helps; the findings name what the
    // recording's motion leaves undetermined (or which values are implausible).
    m += "\n  nothing written; the residuals are within the noise limit, so no missing effect "
         "explains this: the findings name what the recording does not determine (`imubench "
         "plan observe PLAN` shows what a plan determines) or which values are implausible "
         "(result unusable, exit 3)";
  }
  throw CommandFailed(m, kExitResultUnusable);
}

}  // namespace imubench::tools
