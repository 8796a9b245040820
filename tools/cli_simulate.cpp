// imubench simulate PLAN --truth T.json --out DIR [--rate HZ] [--seed N] [--site-lat DEG]
//                   [--site-height M] [--noise none|nav-grade|nav-grade-drift|tactical|consumer]
#include <iostream>
#include <memory>

#include "tools/cli_common.h"
#include "tools/cli_sim.h"

namespace imubench::tools {
namespace {

struct SimulateOptions {
  std::string plan;
  std::string truth;
  std::string out;
  double rate_hz = 200.0;
  double table_rate_hz = 100.0;
  std::uint64_t seed = 1;
  std::string noise = "none";
  SiteOptions site;
};

void runSimulate(const SimulateOptions& o) {
  SimRequest req;
  req.plan_path = o.plan;
  req.truth = loadTruthOrFail(o.truth);
  req.site = o.site;
  req.imu_rate_hz = o.rate_hz;
  req.table_rate_hz = o.table_rate_hz;
  req.seed = o.seed;
  req.noise = *noiseByName(o.noise);  // checked by CLI11
  const SimOutcome sim = simulatePlanOrFail(req);
  writeRecordingOrFail(o.out, recordingOf(sim, req));
  std::cout << "simulated " << sim.plan.name << ": " << sim.sim.imu.size() << " IMU samples ("
            << sim.motion.duration << " s at " << o.rate_hz << " Hz), " << sim.sim.table.size()
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
  sub->add_option("--rate", opt->rate_hz, "IMU output rate, Hz")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  sub->add_option("--table-rate", opt->table_rate_hz, "encoder logging rate, Hz")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  sub->add_option("--seed", opt->seed, "noise seed")->capture_default_str();
  sub->add_option("--noise", opt->noise, std::string("sensor noise: ") + noiseNames())
      ->check(CLI::IsMember({"none", "nav-grade", "nav-grade-drift", "tactical", "consumer"}))
      ->capture_default_str();
  addSiteOptions(*sub, &opt->site);
  sub->callback([opt] { runSimulate(*opt); });
}

}  // namespace imubench::tools
