// imubench run: the main job. With no arguments: the bundled 12-run two-axis plan, the
// embedded default bench truth, simulate, and print per rotation what the simulated IMU saw.
#include <iostream>
#include <memory>

#include "io/truth_file.h"
#include "plans/plan.h"
#include "tools/cli_common.h"
#include "tools/cli_run_report.h"
#include "tools/cli_sim.h"

namespace imubench::tools {
namespace {

constexpr const char* kDefaultPlan = "two_axis_12run.toml";

struct RunOptions {
  std::string plan;   // empty: bundled default
  std::string truth;  // empty: embedded default
  std::string out;    // empty: do not write the recording
  std::string write_truth;
  SimulationOptions sim{200.0, 1, "nav-grade"};
  SiteOptions site;
};

void runMain(const RunOptions& o) {
  SimRequest req;
  req.plan_path = o.plan.empty() ? bundledPlanPath(kDefaultPlan) : o.plan;
  if (req.plan_path.empty()) {
    throw CommandFailed(std::string("bundled plan ") + kDefaultPlan +
                        " not found (neither in the source tree nor installed); give --plan FILE");
  }
  req.truth = o.truth.empty() ? defaultTruth() : loadTruthOrFail(o.truth);
  req.site = o.site;
  req.imu_rate_hz = o.sim.rate_hz;
  req.seed = o.sim.seed;
  req.noise = *noiseByName(o.sim.noise);  // checked by CLI11
  if (!o.write_truth.empty()) {
    const auto st = io::writeTruthFile(o.write_truth, req.truth);
    if (!st.ok) throw CommandFailed(st.message);
  }

  const SimOutcome sim = simulatePlanOrFail(req);
  const auto runs = summarizeRotations(sim.sim.segments, sim.sim.imu);
  std::vector<std::string> axis_names;
  for (auto n : plans::axisNames(sim.motion.kind)) axis_names.emplace_back(n);

  std::cout << "imubench run: plan '" << sim.plan.name << "' (" << req.plan_path << ")\n"
            << "  table " << plans::tableKindName(sim.motion.kind) << ", outer axis heading "
            << sim.plan.table.outer_axis_heading * kRadToDeg << " deg; site " << o.site.latitude_deg
            << " deg N, " << o.site.height_m << " m; IMU " << o.sim.rate_hz << " Hz, noise "
            << o.sim.noise << ", seed " << o.sim.seed << "\n"
            << "  truth: " << (o.truth.empty() ? "embedded default (navigation grade)" : o.truth)
            << "; " << sim.sim.imu.size() << " IMU samples over " << sim.motion.duration << " s, "
            << runs.size() << " rotation runs\n\n";
  std::cout << formatRotationTable(runs, axis_names);
  if (!o.out.empty()) {
    writeRecordingOrFail(o.out, recordingOf(sim, req));
    std::cout << "\nrecording written to " << o.out << "\n";
  }
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto opt = std::make_shared<RunOptions>();
  CLI::App* sub = app.add_subcommand(
      "run", "main job: simulate the 12-run two-axis plan on the default bench, print each run");
  sub->add_option("--plan", opt->plan, "plan file instead of the bundled two_axis_12run.toml");
  sub->add_option("--truth", opt->truth, "bench truth JSON instead of the embedded default");
  sub->add_option("--out", opt->out, "also write the recording (imubench-csv/1) to this directory");
  sub->add_option("--write-truth", opt->write_truth, "write the truth used to this JSON file");
  addSimulationOptions(*sub, &opt->sim);
  addSiteOptions(*sub, &opt->site);
  sub->callback([opt] { runMain(*opt); });
}

}  // namespace imubench::tools
