// Issue 28 item 4 without a bench: a simulated run stored as the daemon stores one that was
// killed inside a rotation (or inside the hold after it) and resumed, calibrated by
// finalCalibration as the daemon's worker does. The stored layout follows the resume rule
// (plan_runner.h resumeAfterGap): the samples before the kill, a gap, then the steps from the
// resume step on; the segments of the steps before the first void one. With that rule the
// calibration agrees with the uninterrupted run's within 3 arcsec / 10 ppm / 3 sigma (biases); with
// the old rule (resume at the interrupted step) calib refuses it (a gap next to a rotation).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "calib/simulator.h"
#include "daemon/online_engine.h"
#include "daemon/plan_runner.h"
#include "daemon/run_calibration.h"
#include "daemon/store.h"
#include "io/sim_recording.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tests/daemon/scratch_dir.h"

namespace imubench::daemon {
namespace {

using testing::ScratchDir;

struct Simulated {
  io::Recording rec;
  std::vector<RunStep> steps;
};

Simulated simulatePlan(const std::string& file, std::uint64_t seed) {
  const std::string path = std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/" + file;
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  EXPECT_TRUE(plan && plans::validatePlan(*plan, diag)) << diag.str();
  if (!plan) return {};
  const plans::ExpandResult e = plans::expand(*plan);
  EXPECT_TRUE(e.status.ok) << e.status.message;
  calib::SimulatorInput in;
  in.motion = e.motion;
  in.world.site.latitude_rad = 55.75 * kDegToRad;
  in.world.site.height_m = 150.0;
  in.world.noise = calib::NoiseModel::navigationGrade();
  in.world.truth.sensors.accel.bias = Vec3(5e-4, -3e-4, 2e-4);
  in.world.truth.sensors.gyro.scale = Vec3(1.0002, 0.9998, 1.0001);
  in.world.truth.sensors.gyro.bias = Vec3(2e-7, -1e-7, 3e-7);
  calib::SimOptions opt;
  opt.imu_rate_hz = 100.0;
  opt.table_rate_hz = 20.0;
  opt.seed = seed;
  const calib::Simulation sim = calib::simulate(in, opt);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;
  io::RecordingIdentity id;
  id.imu_serial = "SIM-RESUME";
  id.imu_rate_hz = opt.imu_rate_hz;
  return {io::recordingFromSimulation(sim, in.world.site, id), runSteps(e.motion)};
}

int stepOf(const std::vector<RunStep>& steps, const std::string& label) {
  for (const RunStep& s : steps) {
    if (s.label == label) return s.index;
  }
  ADD_FAILURE() << "no step " << label;
  return 0;
}

// rec killed `into` seconds into step `killed` and resumed at step `resume` after a 300 s gap;
// the segments of the steps before `first_void` stay. (The re-run is the same simulated data
// shifted in time: the bench at rest, the same physics.)
io::Recording crashResumed(const Simulated& s, int killed, double into, int resume,
                           int first_void) {
  const auto& seg = s.rec.segments;
  const double t_kill = seg[static_cast<std::size_t>(killed)].t0 + into;
  const double t_resume = seg[static_cast<std::size_t>(resume)].t0;
  const double shift = t_kill + 300.0 - t_resume;
  io::Recording out = s.rec;
  out.imu.clear(), out.table.clear(), out.segments.clear();
  for (const auto& x : s.rec.imu) {
    if (x.t <= t_kill) out.imu.push_back(x);
  }
  for (auto x : s.rec.imu) {
    if (x.t > t_resume) out.imu.push_back((x.t += shift, x));
  }
  for (const auto& x : s.rec.table) {
    if (x.t <= t_kill) out.table.push_back(x);
  }
  for (auto x : s.rec.table) {
    if (x.t >= t_resume) out.table.push_back((x.t += shift, x));
  }
  for (int k = 0; k < first_void; ++k) out.segments.push_back(seg[static_cast<std::size_t>(k)]);
  for (std::size_t k = static_cast<std::size_t>(resume); k < seg.size(); ++k) {
    calib::Segment x = seg[k];
    x.t0 += shift, x.t1 += shift;
    out.segments.push_back(x);
  }
  return out;
}

// The daemon's resume rule applied to a kill `into` seconds into step `label`.
io::Recording resumedByTheRule(const Simulated& s, const std::string& label, double into) {
  const int killed = stepOf(s.steps, label);
  const GapRestart r = resumeAfterGap(s.steps, killed - 1);
  return crashResumed(s, killed, into, r.step, r.first_void);
}

FinalCalibration calibrateStored(const ScratchDir& dir, const io::Recording& rec,
                                 plans::CalibrationMethod method,
                                 std::optional<std::int64_t> direct_run = std::nullopt,
                                 const io::Recording* direct = nullptr) {
  OnlineSetup setup;
  setup.db_path = dir.file("bench.db");
  auto opened = Store::open(setup.db_path, StoreOptions{});
  EXPECT_TRUE(opened.status.ok) << opened.status.message;
  if (!opened.status.ok) return {};
  if (direct) {
    RunStart d = runStartFromRecording(*direct);
    d.plan_name = "direct_two_axis";
    direct_run = opened.value->importRecording(d, *direct).value;
  }
  RunStart start = runStartFromRecording(rec);
  start.plan_name = "resumed";
  const RunIdResult run = opened.value->importRecording(start, rec);
  EXPECT_TRUE(run.status.ok) << run.status.message;
  setup.run_id = run.value;
  setup.method = method;
  setup.direct_run = direct_run;
  setup.meta = rec;
  return finalCalibration(setup);
}

// Every parameter of `got` as the uninterrupted run's `want` within the targets:
// 3 arcsec (misalignments, table errors), 10 ppm (scales), 3 sigma of the two (biases).
void expectSameWithinTargets(const nlohmann::json& got, const nlohmann::json& want) {
  ASSERT_FALSE(want["parameters"].empty());
  for (const auto& [name, w] : want["parameters"].items()) {
    ASSERT_TRUE(got["parameters"].contains(name)) << name;
    const auto& g = got["parameters"][name];
    const std::string unit = w["unit"].get<std::string>();
    const double tol = unit == "arcsec" ? 3.0
                       : unit == "ppm"
                           ? 10.0
                           : 3.0 * std::hypot(g["sigma"].get<double>(), w["sigma"].get<double>());
    EXPECT_LE(std::abs(g["value"].get<double>() - w["value"].get<double>()), tol)
        << name << ": " << g.dump() << " vs uninterrupted " << w.dump();
  }
}

const Simulated& direct() {
  static const Simulated s = simulatePlan("direct_two_axis.toml", 7);
  return s;
}

TEST(ResumeCalibration, DirectPlanKilledInARateRunOrTheHoldAfterIt) {
  const io::Recording whole = direct().rec;
  const RunCalibration want =
      calibrateRun(plans::CalibrationMethod::kDirect, whole, nullptr, std::nullopt);
  ASSERT_TRUE(want.status.ok) << want.status.message;
  for (const auto& [label, into] :
       {std::pair{"rate_z_up_pos", 2.0}, std::pair{"rate_z_up_pos_after", 3.5}}) {
    ScratchDir dir("resume-calibration");
    const FinalCalibration f = calibrateStored(dir, resumedByTheRule(direct(), label, into),
                                               plans::CalibrationMethod::kDirect);
    ASSERT_TRUE(f.status.ok) << f.status.message;
    ASSERT_TRUE(f.calibrated) << label << ": " << f.report.dump();
    EXPECT_TRUE(f.explain) << label << ": " << f.explain_error;
    expectSameWithinTargets(f.report["estimate"], estimateJson(want));
  }
  // The old rule (resume at the killed rotation, nothing re-run before it) is refused by calib.
  const int killed = stepOf(direct().steps, "rate_z_up_pos");
  const io::Recording old = crashResumed(direct(), killed, 2.0, killed, killed);
  const RunCalibration refused =
      calibrateRun(plans::CalibrationMethod::kDirect, old, nullptr, std::nullopt);
  EXPECT_FALSE(refused.status.ok);
  EXPECT_NE(refused.status.message.find("next to a rotation"), std::string::npos)
      << refused.status.message;
}

TEST(ResumeCalibration, PipelineRunKilledInAReversal) {
  const Simulated nav = simulatePlan("two_axis_12run.toml", 8);
  const RunCalibration want =
      calibrateRun(plans::CalibrationMethod::kPipeline, nav.rec, &direct().rec, std::nullopt);
  ASSERT_TRUE(want.status.ok) << want.status.message;
  ScratchDir dir("resume-calibration");
  const io::Recording direct_resumed = resumedByTheRule(direct(), "rate_z_up_pos", 2.0);
  const FinalCalibration f =
      calibrateStored(dir, resumedByTheRule(nav, "run02_x_p1", 5.0),
                      plans::CalibrationMethod::kPipeline, std::nullopt, &direct_resumed);
  ASSERT_TRUE(f.status.ok) << f.status.message;
  ASSERT_TRUE(f.calibrated) << f.report.dump();
  EXPECT_TRUE(f.explain) << f.explain_error;
  expectSameWithinTargets(f.report["estimate"], estimateJson(want));
}

}  // namespace
}  // namespace imubench::daemon
