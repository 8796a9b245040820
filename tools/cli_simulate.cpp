// imubench simulate PLAN --truth T.json --out DIR [--rate HZ] [--seed N] [--site-lat DEG]
//                   [--site-height M] [--noise none|nav-grade|nav-grade-drift|tactical|consumer]
//                   [--effect ID.PARAM=V[,V...]]...  (adds to the truth file's "extra")
//                   [--thermal-truth FILE]  (imubench-thermal/1: coefficients over temperature)
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "io/thermal_file.h"
#include "tools/cli_common.h"
#include "tools/cli_sim.h"

namespace imubench::tools {
namespace {

struct SimulateOptions {
  std::string plan;
  std::string truth;
  std::string out;
  SimulationOptions sim{200.0, 1, "none"};
  double table_rate_hz = 100.0;
  SiteOptions site;
  std::vector<std::string> effects;  // "<id>.<param>=<values>", applied over the truth's extra
  std::string thermal_truth;         // imubench-thermal/1 file; empty: coefficients constant
};

void runSimulate(const SimulateOptions& o) {
  SimRequest req;
  req.plan_path = o.plan;
  req.truth = loadTruthOrFail(o.truth);
  for (const std::string& e : o.effects) {
    std::string why;
    if (!calib::setEffectParamFromText(&req.truth.extra, e, &why)) {
      throw CommandFailed("--effect " + why);
    }
  }
  if (!o.thermal_truth.empty()) {
    const io::ThermalFileResult t = io::readThermalFile(o.thermal_truth);
    if (!t.status.ok) throw CommandFailed("--thermal-truth " + t.status.message);
    req.thermal = t.value.coefficients;
  }
  req.site = o.site;
  req.imu_rate_hz = o.sim.rate_hz;
  req.table_rate_hz = o.table_rate_hz;
  req.seed = o.sim.seed;
  req.noise = *noiseByName(o.sim.noise);  // checked by CLI11
  const SimOutcome sim = simulatePlanOrFail(req);
  writeRecordingOrFail(o.out, recordingOf(sim, req));
  std::cout << "simulated " << sim.plan.name << ": " << sim.sim.imu.size() << " IMU samples ("
            << sim.motion.duration << " s at " << o.sim.rate_hz << " Hz), " << sim.sim.table.size()
            << " table samples, " << sim.sim.segments.size() << " segments -> " << o.out << "\n";
}

}  // namespace

void addSimulateCommand(CLI::App& app) {
  auto opt = std::make_shared<SimulateOptions>();
  CLI::App* sub =
      app.add_subcommand("simulate", "simulate a plan into an imubench-csv/1 recording");
  sub->add_option("plan", opt->plan, "plan file (TOML)")->required()->check(CLI::ExistingFile);
  sub->add_option("--truth", opt->truth, "bench truth JSON (interchange.md coefficient file)")
      ->required();
  sub->add_option("--out", opt->out, "output recording directory")->required();
  addSimulationOptions(*sub, &opt->sim);
  sub->add_option("--table-rate", opt->table_rate_hz, "encoder logging rate, Hz")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  addSiteOptions(*sub, &opt->site);
  sub->add_option("--effect", opt->effects,
                  "switch an effect on / set one parameter (interchange.md effect ids), e.g. "
                  "lever_arm.r_m=0.05,-0.03,0.02 or angle_harmonic.axis=inner; repeatable, "
                  "applied over the truth file's \"extra\"");
  sub->add_option("--thermal-truth", opt->thermal_truth,
                  "imubench-thermal/1 file: every sensor coefficient over the IMU temperature "
                  "(replaces the truth file's accel/gyro)")
      ->check(CLI::ExistingFile);
  sub->callback([opt] { runSimulate(*opt); });
}

}  // namespace imubench::tools
