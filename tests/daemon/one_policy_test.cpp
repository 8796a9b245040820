// One calibration policy (calib/calibration_service.h): the same recording, written as an
// imubench-csv/1 directory, gives identical coefficients through the three front ends that
// calibrate it: `imubench calibrate DIR --json` (the real CLI process), the daemon's
// end-of-plan calibration (daemon/run_calibration.h calibrateRun, on the recording read back
// from the directory) and explain's baseline (calib/explain_baseline.h). Identical means the
// same values to the last bit the JSON carries (17 significant digits) and the same
// unobservable flags.
#include <gtest/gtest.h>
#include <stdio.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/explain_baseline.h"
#include "calib/simulator.h"
#include "daemon/run_calibration.h"
#include "io/recording.h"
#include "nav/rotation.h"
#include "io/sim_recording.h"
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

// `imubench calibrate DIR --json`: its coefficient JSON (exit code in *rc).
nlohmann::json cliCoefficients(const std::string& dir, int* rc) {
  const std::string cmd = std::string(IMUBENCH_CLI) + " calibrate " + dir + " --json 2>/dev/null";
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(cmd.c_str(), "r"), pclose);
  std::string out;
  std::array<char, 4096> buf{};
  while (p && fgets(buf.data(), buf.size(), p.get())) out += buf.data();
  *rc = p ? pclose(p.release()) : -1;
  return nlohmann::json::parse(out, nullptr, false);
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

struct Case {
  const char* plan;
  plans::CalibrationMethod daemon_method;  // the method the bundled plan names
  double table_error_arcsec;               // every base tilt and nonorthogonality term
};

class OnePolicy : public ::testing::TestWithParam<Case> {};

TEST_P(OnePolicy, CliDaemonAndExplainBaselineGiveIdenticalCoefficients) {
  const Case c = GetParam();
  ScratchDir dir("policy");
  calib::TableErrors table;
  const double e = c.table_error_arcsec * kArcsecToRad;
  table.base_tilt = Vec2(e, -0.8 * e);
  table.nonorthogonality.inner_y = 0.6 * e;
  const io::Recording rec = writtenRecording(c.plan, table, dir.file("rec"));
  ASSERT_FALSE(rec.imu.empty());

  int rc = 0;
  const nlohmann::json j = cliCoefficients(dir.file("rec"), &rc);
  ASSERT_EQ(rc, 0) << "imubench calibrate exit status";
  calib::CoefficientReport cli;
  std::string why;
  ASSERT_TRUE(calib::fromJson(j, &cli, &why)) << why;

  const RunCalibration daemon = calibrateRun(c.daemon_method, rec, nullptr);
  ASSERT_TRUE(daemon.status.ok) << daemon.status.message;
  EXPECT_TRUE(daemon.fit.IsSolutionUsable()) << daemon.fit.message;

  const io::CalibrationView view(rec);
  const calib::BaselineCalibration base = calib::calibrateBaseline(view.view());
  ASSERT_TRUE(base.status.HasResult()) << base.status.message;
  EXPECT_EQ(base.method, daemon.baseline_method);
  EXPECT_EQ(base.table_params, daemon.table_params);

  expectSame(cli, daemon.coefficients, "CLI vs daemon");
  expectSame(cli, base.coefficients, "CLI vs explain baseline");
}

INSTANTIATE_TEST_SUITE_P(
    Recordings, OnePolicy,
    ::testing::Values(Case{"direct_two_axis", plans::CalibrationMethod::kDirect, 0.0},
                      Case{"two_axis_12run", plans::CalibrationMethod::kIndirect, 30.0}),
    [](const ::testing::TestParamInfo<Case>& i) {
      return std::string(i.param.daemon_method == plans::CalibrationMethod::kDirect
                             ? "DirectPlanLevelTable"
                             : "TwelveRunPlanTableErrors30arcsec");
    });

}  // namespace
}  // namespace imubench::daemon
