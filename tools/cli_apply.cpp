// imubench apply comp.json RUN_OR_DIR --out DIR [--rate-window S]
// Compensates a recording sample by sample with an imubench-thermal/1 model at each sample's
// IMU temperature and its rate (calib/thermal_model.h, the fit's own model) and writes the
// compensated recording (increments of the true inputs) to DIR. Samples outside the model's
// calibrated range are compensated at the range edge and flagged: DIR/extrapolated.csv lists
// the spans (t0,t1,temp_min_c,temp_max_c) and stderr says how many. Refusals (exit 1): a
// compensation file for another IMU serial, a recording without temperatures.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "calib/thermal_model.h"
#include "io/recording.h"
#include "io/thermal_file.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

struct ApplyOptions {
  std::string comp;
  std::string run;
  std::string db;  // run store for run ids
  std::string out;
  double rate_window_s = 60.0;
};

// Spans of consecutive flagged samples as CSV text.
std::string extrapolatedSpans(const nav::ImuSamples& imu, const std::vector<bool>& flag) {
  std::ostringstream os;
  os.precision(10);
  os << "t0,t1,temp_min_c,temp_max_c\n";
  for (std::size_t i = 0; i < imu.size();) {
    if (!flag[i]) {
      ++i;
      continue;
    }
    double lo = imu[i].temp_c, hi = imu[i].temp_c;
    std::size_t j = i;
    for (; j < imu.size() && flag[j]; ++j) {
      lo = std::min(lo, imu[j].temp_c);
      hi = std::max(hi, imu[j].temp_c);
    }
    os << imu[i].t << ',' << imu[j - 1].t << ',' << lo << ',' << hi << '\n';
    i = j;
  }
  return os.str();
}

void runApply(const ApplyOptions& o) {
  const io::ThermalFileResult comp = io::readThermalFile(o.comp);
  if (!comp.status.ok) throw CommandFailed(comp.status.message);
  ResolvedRecording rec = loadRunOrDir(o.run, o.db);
  const std::string& want = comp.value.imu_serial;
  if (!want.empty() && want != rec.recording.imu_serial) {
    throw CommandFailed(o.comp + ": compensation file for IMU serial '" + want + "', but " + o.run +
                        " was recorded with IMU '" + rec.recording.imu_serial + "'");
  }
  calib::ThermalApplyOptions ao;
  ao.rate.window_s = o.rate_window_s;
  const calib::ThermalApplyResult r =
      calib::applyThermal(comp.value.coefficients, rec.recording.imu, ao);
  if (!r.status.ok)
    throw CommandFailed(o.run + "/imu.csv: " + r.status.message + "; nothing to compensate with");
  io::Recording out = std::move(rec.recording);
  out.imu = r.compensated;
  if (auto st = io::writeRecording(o.out, out); !st.ok) throw CommandFailed(st.message);
  const std::string spans_path = (std::filesystem::path(o.out) / "extrapolated.csv").string();
  const std::string spans = extrapolatedSpans(out.imu, r.extrapolated);
  std::FILE* f = std::fopen(spans_path.c_str(), "wb");
  if (!f || std::fwrite(spans.data(), 1, spans.size(), f) != spans.size() || std::fclose(f)) {
    throw CommandFailed(spans_path + ": cannot write");
  }
  const auto& c = comp.value.coefficients;
  std::cout << "compensated " << out.imu.size() << " samples (" << r.temp_min_c << " .. "
            << r.temp_max_c << " degC) -> " << o.out << "\n";
  if (r.extrapolated_count > 0) {
    std::cerr << "imubench: warning: EXTRAPOLATED: " << r.extrapolated_count << " of "
              << out.imu.size() << " samples outside the calibrated range " << c.t_min_c << " .. "
              << c.t_max_c << " degC (compensated at the edge; spans in " << spans_path << ")\n";
  }
}

}  // namespace

void addApplyCommand(CLI::App& app) {
  auto opt = std::make_shared<ApplyOptions>();
  CLI::App* sub = app.add_subcommand(
      "apply", "compensate a recording with a thermal model (imubench-thermal/1)");
  sub->add_option("comp", opt->comp, "compensation file (imubench thermal fit --out)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("run", opt->run,
                  "recording with temperatures: imubench-csv/1 directory or run id (N, run:N)")
      ->required();
  sub->add_option("--out", opt->out, "output recording directory")->required();
  addStoreOption(*sub, &opt->db);
  sub->add_option("--rate-window", opt->rate_window_s, "window of the temperature-rate estimate, s")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->callback([opt] { runApply(*opt); });
}

}  // namespace imubench::tools
