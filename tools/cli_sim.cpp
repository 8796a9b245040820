#include "tools/cli_sim.h"

#include <iostream>

#include "io/sim_recording.h"
#include "plans/expand.h"
#include "plans/validator.h"

namespace imubench::tools {

SimOutcome simulatePlanOrFail(const SimRequest& request) {
  SimOutcome out;
  io::Diagnostics diag(request.plan_path);
  auto plan = plans::loadPlanFile(request.plan_path, diag);
  if (plan) plans::validatePlan(*plan, diag);
  if (!plan || !diag.ok()) {
    std::cerr << diag.str() << "\n";
    throw CommandFailed(request.plan_path + ": plan has errors, nothing simulated");
  }
  out.plan = std::move(*plan);
  auto expanded = plans::expand(out.plan);
  if (!expanded.status.ok)
    throw CommandFailed(request.plan_path + ": cannot expand: " + expanded.status.message);
  out.motion = std::move(expanded.motion);

  calib::SimulatorInput input;
  out.site = request.site.site();
  input.world.site = out.site;
  input.world.outer_axis_heading_rad = out.plan.table.outer_axis_heading;
  input.world.truth = request.truth;
  input.world.noise = request.noise;
  input.world.thermal = request.thermal;
  input.motion = out.motion;
  calib::SimOptions options;
  options.imu_rate_hz = request.imu_rate_hz;
  options.table_rate_hz = request.table_rate_hz;
  options.seed = request.seed;
  std::string why;
  if (!options.IsValid(&why)) throw CommandFailed("simulation options: " + why);
  out.sim = calib::simulate(input, options);
  if (!out.sim.status.ok) throw CommandFailed("simulation failed: " + out.sim.status.message);
  return out;
}

io::Recording recordingOf(const SimOutcome& outcome, const SimRequest& request) {
  io::RecordingIdentity id;
  id.imu_serial = "SIM-" + std::to_string(request.seed);
  id.imu_rate_hz = request.imu_rate_hz;
  id.outer_axis_heading_rad = outcome.plan.table.outer_axis_heading;
  return io::recordingFromSimulation(outcome.sim, outcome.site, id);
}

void writeRecordingOrFail(const std::string& dir, const io::Recording& rec) {
  const auto st = io::writeRecording(dir, rec);
  if (!st.ok) throw CommandFailed(st.message);
}

}  // namespace imubench::tools
