// One calibration policy (calib/service/calibration_service.h): the same recording, written as an
// imubench-csv/1 directory, gives identical coefficients through the three front ends that
// calibrate it: `imubench calibrate DIR --json` (the real CLI process), the daemon's
// end-of-plan calibration (daemon/run_calibration.h calibrateRun, on the recording read back
// from the directory) and explain's baseline (calib/explain/explain_baseline.h). Identical means
// the same values to the last bit the JSON carries (17 significant digits) and the same
// unobservable flags.
#include <gtest/gtest.h>
#include <stdio.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/explain/explain_baseline.h"
#include "calib/simulator.h"
#include "daemon/run_calibration.h"
#include "io/recording.h"
#include "io/sim_recording.h"
#include "io/truth_file.h"
#include "nav/rotation.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tests/daemon/scratch_dir.h"

namespace imubench::daemon {
namespace {

using testing::ScratchDir;

// A bundled plan simulated at 100 Hz with sensor errors, the given table errors and
// navigation-grade noise, written to dir and read back as the daemon and the CLI read it.
io::Recording writtenRecording(const std::string& plan_name, const calib::TableErrors& table,
                               const std::string& dir) {
  const std::string path =
      std::string(IMUBENCH_SOURCE_DIR) + "/plans/library/" + plan_name + ".toml";
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
  in.world.truth.sensors.accel.scale = Vec3(1.0003, 0.9996, 1.0002);
  in.world.truth.sensors.accel.bias = Vec3(5e-4, -3e-4, 2e-4);
  in.world.truth.sensors.gyro.scale = Vec3(1.0002, 0.9998, 1.0001);
  in.world.truth.sensors.gyro.bias = Vec3(2e-7, -1e-7, 3e-7);
  in.world.truth.table = table;
  calib::SimOptions opt;
  opt.imu_rate_hz = 100.0;
  opt.table_rate_hz = 100.0;
  opt.seed = 777;
  const calib::Simulation sim = calib::simulate(in, opt);
  EXPECT_TRUE(sim.status.ok) << sim.status.message;
  io::RecordingIdentity id;
  id.imu_serial = "SIM-POLICY";
  id.imu_rate_hz = opt.imu_rate_hz;
  const Status w = io::writeRecording(dir, io::recordingFromSimulation(sim, in.world.site, id));
  EXPECT_TRUE(w.ok) << w.message;
  io::RecordingReadResult r = io::readRecording(dir);
  EXPECT_TRUE(r.ok()) << r.status.message;
  return r.value;
}

// `imubench calibrate DIR [--direct DIRECT] --json`: its coefficient JSON (exit code in *rc).
std::string commandOutput(const std::string& cmd, int* rc) {
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(cmd.c_str(), "r"), pclose);
  std::string out;
  std::array<char, 4096> buf{};
  while (p && fgets(buf.data(), buf.size(), p.get())) out += buf.data();
  *rc = p ? pclose(p.release()) : -1;
  return out;
}

nlohmann::json cliCoefficients(const std::string& dir, const std::string& direct, int* rc,
                               const std::string& extra = "") {
  const std::string cmd = std::string(IMUBENCH_CLI) + " calibrate " + dir +
                          (direct.empty() ? "" : " --direct " + direct) + extra +
                          " --json 2>/dev/null";
  nlohmann::json j = nlohmann::json::parse(commandOutput(cmd, rc), nullptr, false);
  if (j.is_object()) j.erase("calibration");  // the method's report beside the coefficients
  return j;
}

// The three front ends agree on every coefficient (value and observability).
void expectSame(const calib::CoefficientReport& a, const calib::CoefficientReport& b,
                const std::string& what) {
  const std::vector<std::string> names = calib::flatNames(a.values);
  ASSERT_EQ(names, calib::flatNames(b.values)) << what;
  for (const std::string& n : names) {
    const double va = calib::flatValue(a.values, n).value_or(NAN);
    const double vb = calib::flatValue(b.values, n).value_or(NAN);
    EXPECT_EQ(va, vb) << what << ": " << n;
    const auto ua = a.uncertainty.find(n), ub = b.uncertainty.find(n);
    const bool oa = ua == a.uncertainty.end() || ua->second.observable;
    const bool ob = ub == b.uncertainty.end() || ub->second.observable;
    EXPECT_EQ(oa, ob) << what << ": observable " << n;
  }
}

// A table with errors: every base tilt and nonorthogonality term of this size.
calib::TableErrors tableWithErrors(double arcsec) {
  calib::TableErrors table;
  const double e = arcsec * kArcsecToRad;
  table.base_tilt = Vec2(e, -0.8 * e);
  table.nonorthogonality.inner_y = 0.6 * e;
  return table;
}

// The bundled direct plan on a level table: the direct calibration, wherever it is asked.
TEST(OnePolicy, DirectPlanGivesIdenticalCoefficientsInCliDaemonAndExplainBaseline) {
  ScratchDir dir("policy");
  const io::Recording rec = writtenRecording("direct_two_axis", {}, dir.file("direct"));
  ASSERT_FALSE(rec.imu.empty());
  int rc = 0;
  const nlohmann::json j = cliCoefficients(dir.file("direct"), "", &rc);
  ASSERT_EQ(rc, 0) << "imubench calibrate exit status";
  calib::CoefficientReport cli;
  std::string why;
  ASSERT_TRUE(calib::fromJson(j, &cli, &why)) << why;

  const RunCalibration daemon =
      calibrateRun(plans::CalibrationMethod::kDirect, rec, nullptr, std::nullopt);
  ASSERT_TRUE(daemon.status.ok) << daemon.status.message;
  EXPECT_TRUE(daemon.fit.IsSolutionUsable()) << daemon.fit.message;

  const io::CalibrationView view(rec);
  const calib::BaselineCalibration base = calib::calibrateBaseline(view.view());
  ASSERT_TRUE(base.status.HasResult()) << base.status.message;
  EXPECT_EQ(base.method, "direct");
  EXPECT_EQ(base.method, daemon.baseline_method);
  EXPECT_EQ(base.table_params, daemon.table_params);
  expectSame(cli, daemon.coefficients, "CLI vs daemon");
  expectSame(cli, base.coefficients, "CLI vs explain baseline");
  // The stored report names the software that calibrated (the certificate's "calibrated by"):
  // the same build as the CLI's --version, with its commit.
  std::string version = commandOutput(std::string(IMUBENCH_CLI) + " --version", &rc);
  ASSERT_EQ(rc, 0) << "imubench --version exit status";
  while (!version.empty() && version.back() == '\n') version.pop_back();
  EXPECT_NE(version.find("imubench "), std::string::npos) << version;
  EXPECT_EQ(daemon.report.value("software", std::string()), version);
}

// The production pipeline on a table with 30 arcsec errors: `calibrate NAV --direct DIRECT`,
// the daemon's pipeline plan, `explain NAV --direct DIRECT`'s baseline.
TEST(OnePolicy, PipelineGivesIdenticalCoefficientsInCliDaemonAndExplainBaseline) {
  ScratchDir dir("policy");
  const calib::TableErrors table = tableWithErrors(30.0);
  const io::Recording direct = writtenRecording("direct_two_axis", table, dir.file("direct"));
  const io::Recording nav = writtenRecording("two_axis_12run", table, dir.file("nav"));
  ASSERT_FALSE(direct.imu.empty());
  ASSERT_FALSE(nav.imu.empty());
  int rc = 0;
  const nlohmann::json j = cliCoefficients(dir.file("nav"), dir.file("direct"), &rc);
  ASSERT_EQ(rc, 0) << "imubench calibrate exit status";
  calib::CoefficientReport cli;
  std::string why;
  ASSERT_TRUE(calib::fromJson(j, &cli, &why)) << why;

  const RunCalibration daemon =
      calibrateRun(plans::CalibrationMethod::kPipeline, nav, &direct, std::nullopt);
  ASSERT_TRUE(daemon.status.ok) << daemon.status.message;
  EXPECT_TRUE(daemon.fit.IsSolutionUsable()) << daemon.fit.message;

  const io::CalibrationView nview(nav), dview(direct);
  const calib::BaselineCalibration base = calib::calibrateBaseline(nview.view(), dview.view());
  ASSERT_TRUE(base.status.HasResult()) << base.status.message;
  EXPECT_EQ(base.method, "indirect");
  EXPECT_EQ(base.method, daemon.baseline_method);
  EXPECT_EQ(base.table_params, daemon.table_params);
  expectSame(cli, daemon.coefficients, "CLI vs daemon");
  expectSame(cli, base.coefficients, "CLI vs explain baseline");
  EXPECT_NEAR(cli.values.table.base_tilt.x(), table.base_tilt.x(), 3.0 * kArcsecToRad);
  EXPECT_NEAR(cli.values.table.nonorthogonality.inner_y, table.nonorthogonality.inner_y,
              3.0 * kArcsecToRad);
}

// The bundled direct plan on a table with 30" errors: the direct method takes the table as
// nominal, so its fit is unusable and the run gets no verdict (the CLI refuses the same fit,
// exit 3). With the table's certified errors given (the bench file's [table] errors, the
// CLI's --table-errors) the fit reaches the noise, the two front ends agree and the verdict
// is a verdict.
TEST(OnePolicy, DirectPlanOnATableWithErrorsNeedsTheTablesCertificationForAVerdict) {
  ScratchDir dir("policy");
  const calib::TableErrors table = tableWithErrors(30.0);
  const io::Recording rec = writtenRecording("direct_two_axis", table, dir.file("direct"));
  ASSERT_FALSE(rec.imu.empty());
  const std::vector<AcceptanceLimit> limits = {{"accel.scale", 1e-3, "1000 ppm"},
                                               {"gyro.bias", 1.0 * kDegToRad / 3600.0, "1 deg/h"}};

  const RunCalibration unknown =
      calibrateRun(plans::CalibrationMethod::kDirect, rec, nullptr, std::nullopt);
  ASSERT_TRUE(unknown.status.ok) << unknown.status.message;
  EXPECT_FALSE(unknown.fit.IsSolutionUsable());
  const nlohmann::json none = acceptanceVerdict(unknown, limits);
  EXPECT_TRUE(none["pass"].is_null()) << none.dump(2);
  EXPECT_EQ(none["usable"], false);
  EXPECT_NE(none["why"].get<std::string>().find("[table] errors"), std::string::npos);
  int rc = 0;
  (void)cliCoefficients(dir.file("direct"), "", &rc, " --method direct");
  EXPECT_EQ(WEXITSTATUS(rc), 3) << "imubench calibrate refuses the same fit";

  calib::BenchTruth certification;
  certification.table = table;
  ASSERT_TRUE(io::writeTruthFile(dir.file("table.json"), certification).ok);
  const RunCalibration known = calibrateRun(plans::CalibrationMethod::kDirect, rec, nullptr, table);
  ASSERT_TRUE(known.status.ok) << known.status.message;
  EXPECT_TRUE(known.fit.IsSolutionUsable()) << known.fit.message;
  const nlohmann::json verdict = acceptanceVerdict(known, limits);
  EXPECT_EQ(verdict["pass"], true) << verdict.dump(2);
  const nlohmann::json j = cliCoefficients(
      dir.file("direct"), "", &rc, " --method direct --table-errors " + dir.file("table.json"));
  ASSERT_EQ(rc, 0) << "imubench calibrate --table-errors exit status";
  calib::CoefficientReport cli;
  std::string why;
  ASSERT_TRUE(calib::fromJson(j, &cli, &why)) << why;
  expectSame(cli, known.coefficients, "CLI --table-errors vs daemon [table] errors");
  EXPECT_NEAR(known.coefficients.values.sensors.accel.scale.x(), 1.0003, 5e-6);
}

}  // namespace
}  // namespace imubench::daemon
