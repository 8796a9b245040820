// The end-of-plan missing-physics analysis (daemon/run_explain.h) through finalCalibration, as
// the daemon's worker runs it: a simulated direct plan stored in a scratch store, calibrated,
// analysed; the report is imubench-explain/1 with the run's own calibration as the baseline. A
// failing analysis stores nothing, leaves the calibration alone and notes why in the verdict.
#include "daemon/run_explain.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "calib/simulator.h"
#include "daemon/online_engine.h"
#include "daemon/store.h"
#include "io/sim_recording.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tests/daemon/recording_fixtures.h"

namespace imubench::daemon {
namespace {

namespace fs = std::filesystem;

using testing::ScratchDir;

// The bundled direct two-axis plan simulated at 100 Hz with sensor errors and navigation-grade
// noise, as a stored run would load.
io::Recording directPlanRecording() {
  const std::string path = std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/direct_two_axis.toml";
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
  opt.table_rate_hz = 100.0;
  opt.seed = 4242;
  const calib::Simulation sim = calib::simulate(in, opt);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;
  io::RecordingIdentity id;
  id.imu_serial = "SIM-EXPLAIN";
  id.imu_rate_hz = opt.imu_rate_hz;
  return io::recordingFromSimulation(sim, in.world.site, id);
}

// The run stored in a fresh store; the setup finalCalibration gets for it.
OnlineSetup storedRun(const ScratchDir& dir, const io::Recording& rec) {
  OnlineSetup setup;
  setup.db_path = dir.file("bench.db");
  auto opened = Store::open(setup.db_path, StoreOptions{});
  EXPECT_TRUE(opened.status.ok) << opened.status.message;
  if (!opened.status.ok) return setup;
  RunStart start = runStartFromRecording(rec);
  start.plan_name = "direct-two-axis";
  start.bench_name = "bench-a";
  const RunIdResult run = opened.value->importRecording(start, rec);
  EXPECT_TRUE(run.status.ok) << run.status.message;
  setup.run_id = run.value;
  setup.method = plans::CalibrationMethod::kDirect;
  setup.meta = rec;
  return setup;
}

const io::Recording& recording() {
  static const io::Recording rec = directPlanRecording();
  return rec;
}

TEST(RunExplain, FinalCalibrationStoresAnExplainReportFromItsOwnCoefficients) {
  ScratchDir dir("explain");
  const OnlineSetup setup = storedRun(dir, recording());
  const FinalCalibration f = finalCalibration(setup);
  ASSERT_TRUE(f.status.ok) << f.status.message;
  ASSERT_TRUE(f.calibrated) << f.report.dump(2);
  ASSERT_TRUE(f.explain.has_value()) << f.explain_error;
  EXPECT_TRUE(f.explain_error.empty());
  EXPECT_FALSE(f.verdict.contains("notes")) << f.verdict.dump(2);
  // The stored text parses back as the interchange report.
  const nlohmann::json j = nlohmann::json::parse(f.explain->dump());
  EXPECT_EQ(j.at("format"), "imubench-explain/1");
  EXPECT_EQ(j.at("baseline").at("method"), "direct");  // the run's method, not "given"
  for (const char* key : {"noise_floor", "rms_before", "rms_after", "accepted", "rejected",
                          "unseparable", "unexplained", "coefficients"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  for (const char* triad : {"accel", "gyro"}) {
    ASSERT_EQ(j["rms_before"][triad].size(), 3u);
    ASSERT_EQ(j["rms_after"][triad].size(), 3u);
    ASSERT_EQ(j["noise_floor"][triad].size(), 3u);
    for (int i = 0; i < 3; ++i) EXPECT_GT(j["noise_floor"][triad][i].get<double>(), 0.0);
  }
  // Its coefficients are a coefficient file; with no physics added to the simulation the
  // refit starts from (and stays near) the run's own calibration: the simulated gyro scale.
  calib::CoefficientReport coefficients;
  std::string why;
  ASSERT_TRUE(calib::fromJson(j["coefficients"], &coefficients, &why)) << why;
  EXPECT_NEAR(coefficients.values.sensors.gyro.scale.x(), 1.0002, 20e-6);
  EXPECT_TRUE(j["accepted"].empty()) << j["accepted"].dump(2);
  EXPECT_NE(f.explain_summary.find("direct baseline"), std::string::npos) << f.explain_summary;
  EXPECT_NE(f.explain_summary.find("no effect accepted"), std::string::npos) << f.explain_summary;
}

TEST(RunExplain, AFailedAnalysisStoresNothingAndNotesWhyInTheVerdict) {
  ScratchDir dir("explain");
  OnlineSetup setup = storedRun(dir, recording());
  // No hold of the plan is a day long: no noise floor, so no analysis.
  setup.explain.min_static_s = 86400.0;
  const FinalCalibration f = finalCalibration(setup);
  ASSERT_TRUE(f.status.ok) << f.status.message;
  EXPECT_TRUE(f.calibrated) << f.report.dump(2);  // the run's calibration is untouched
  EXPECT_FALSE(f.coefficients.is_null());
  EXPECT_FALSE(f.explain.has_value());
  EXPECT_NE(f.explain_error.find("no static hold"), std::string::npos) << f.explain_error;
  ASSERT_TRUE(f.verdict.contains("notes")) << f.verdict.dump(2);
  ASSERT_EQ(f.verdict["notes"].size(), 1u);
  EXPECT_EQ(f.verdict["notes"][0], f.explain_error);
}

TEST(RunExplain, NoAnalysisWithoutACalibrationToStartFrom) {
  RunCalibration failed;
  failed.status = Status::Error("direct calibration: too few positions");
  const RunExplain e = explainRun(plans::CalibrationMethod::kDirect, recording(), failed);
  EXPECT_FALSE(e.status.ok);
  EXPECT_NE(e.status.message.find("too few positions"), std::string::npos) << e.status.message;
  EXPECT_TRUE(e.report.is_null());
}

TEST(RunExplain, BaselineIsWhatTheCalibrationServiceEstimated) {
  // The direct calibration holds every table error at zero: the analysis' baseline is
  // "direct" with no table parameter, so each table error stays a candidate effect.
  const RunCalibration d =
      calibrateRun(plans::CalibrationMethod::kDirect, recording(), nullptr, std::nullopt);
  ASSERT_TRUE(d.status.ok) << d.status.message;
  EXPECT_EQ(d.baseline_method, "direct");
  EXPECT_TRUE(d.table_params.empty());
  ASSERT_TRUE(d.report.contains("table")) << d.report.dump(2);
  for (const auto& row : d.report["table"]) {
    EXPECT_FALSE(row["estimated"].get<bool>()) << row.dump();
    EXPECT_FALSE(row["reason"].get<std::string>().empty()) << row.dump();
  }
}

}  // namespace
}  // namespace imubench::daemon
