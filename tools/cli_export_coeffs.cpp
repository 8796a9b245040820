// imubench export-coeffs COEFFS.json --to kalibr|openvins|px4|ardupilot|csv [--thermal comp.json]
//                        [--recording DIR] --out FILE
// The coefficient file (interchange.md) in a flight or VIO tool's own convention
// (io/coeff_export.h, docs/export.md). Kalibr and OpenVINS need noise densities and random
// walks, which a coefficient file does not hold: --recording DIR (the calibration recording)
// gives them from the Allan deviation of its static holds. Every term the target cannot carry
// is printed (stderr) with the residual error it leaves, and written in the file's header.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "calib/explain/explain_noise.h"
#include "io/coeff_export.h"
#include "io/recording.h"
#include "io/thermal_file.h"
#include "io/truth_file.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

struct ExportOptions {
  std::string coeffs;
  std::string to;
  std::string thermal;
  std::string recording;
  std::string out;
};

// The static holds of a recording as readings (increments over their intervals).
std::vector<calib::HoldReadings> holds(const io::Recording& rec) {
  std::vector<calib::HoldReadings> out;
  for (const calib::Segment& s : rec.segments) {
    if (s.kind != calib::SegmentKind::kStatic) continue;
    calib::HoldReadings h;
    double prev = std::nan("");
    for (const nav::ImuSample& x : rec.imu) {
      if (x.t > s.t0 && x.t <= s.t1 && std::isfinite(prev)) {
        const double dt = x.t - prev;
        h.accel.push_back(x.dvel / dt);
        h.gyro.push_back(x.dtheta / dt);
      }
      prev = x.t;
    }
    h.dt = 1.0 / rec.imu_rate_hz;
    if (h.accel.size() > 16) out.push_back(std::move(h));
  }
  return out;
}

// White-noise density and bias random walk per channel from the Allan deviation: the random
// walk K from adev(tau) = K sqrt(tau / 3) at the longest tau (an upper bound where the curve
// has not turned up yet: adev >= K sqrt(tau/3) everywhere).
io::NoiseEstimate noiseOf(const std::string& dir) {
  const io::RecordingReadResult rec = io::readRecording(dir);
  if (!rec.status.ok) throw CommandFailed(rec.status.message);
  const std::vector<calib::HoldReadings> h = holds(rec.value);
  const calib::NoiseFloor nf = calib::noiseFloor(h);
  if (!nf.status.ok) throw CommandFailed(dir + ": noise: " + nf.status.message);
  io::NoiseEstimate n;
  n.static_s = nf.total_static_s;
  n.rate_hz = rec.value.imu_rate_hz;
  n.source = "Allan deviation of the static holds of " + dir;
  const calib::AllanPoint& last = nf.curve.back();
  for (int c = 0; c < calib::kExplainChannels; ++c) {
    io::TriadNoise& t = c < 3 ? n.accel : n.gyro;
    const auto k = static_cast<std::size_t>(c % 3);
    t.density[k] = nf.white[static_cast<std::size_t>(c)];
    t.random_walk[k] = last.adev[static_cast<std::size_t>(c)] * std::sqrt(3.0 / last.tau_s);
    const double minimum = nf.bias_instability[static_cast<std::size_t>(c)] * 0.664;
    if (!(last.adev[static_cast<std::size_t>(c)] > 1.5 * minimum)) t.random_walk_bound = true;
  }
  return n;
}

void runExport(const ExportOptions& o) {
  io::ExportTarget target;
  if (!io::exportTargetFromName(o.to, &target))
    throw CommandFailed("--to: kalibr, openvins, px4, ardupilot or csv", 2);
  const io::CoefficientFileResult c = io::readCoefficientFile(o.coeffs);
  if (!c.status.ok) throw CommandFailed(c.status.message);
  io::ExportInput in;
  in.source = o.coeffs;
  in.sensors = c.value.values.sensors;
  if (c.value.values.extra.gyro_g_sensitivity)
    in.gyro_g_sens = c.value.values.extra.gyro_g_sensitivity->G;
  if (!o.thermal.empty()) {
    const io::ThermalFileResult t = io::readThermalFile(o.thermal);
    if (!t.status.ok) throw CommandFailed(t.status.message);
    in.thermal = t.value;
  }
  if (!o.recording.empty()) in.noise = noiseOf(o.recording);
  const io::ExportResult r = io::exportCoefficients(target, in);
  if (!r.status.ok) throw CommandFailed(o.to + ": " + r.status.message, 2);
  std::ofstream f(o.out, std::ios::binary);
  if (!f || !(f << r.text) || !f.flush()) throw CommandFailed(o.out + ": cannot write");
  for (const std::string& d : r.dropped)
    std::cerr << "imubench: " << o.to << " drops " << d << "\n";
  std::cout << "wrote " << o.out << " (" << o.to << "; conventions in docs/export.md)\n";
}

}  // namespace

void addExportCoeffsCommand(CLI::App& app) {
  auto opt = std::make_shared<ExportOptions>();
  CLI::App* sub = app.add_subcommand(
      "export-coeffs", "coefficients in Kalibr/OpenVINS/PX4/ArduPilot/CSV conventions");
  sub->add_option("coeffs", opt->coeffs, "coefficient file (calibrate --out)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--to", opt->to, "kalibr | openvins | px4 | ardupilot | csv")->required();
  sub->add_option("--thermal", opt->thermal,
                  "imubench-thermal/1 file: PX4 TC_* / ArduPilot INS_TCAL* from it");
  sub->add_option("--recording", opt->recording,
                  "calibration recording: noise densities and random walks from the Allan "
                  "deviation of its static holds (kalibr, openvins)");
  sub->add_option("--out", opt->out, "output file")->required();
  sub->callback([opt] { runExport(*opt); });
}

}  // namespace imubench::tools
