// imubench-thermal/1 files: JSON round trip (every value, order and hysteresis flag), the CSV
// form, refusals naming the JSON path; and the compensation undoing the simulator's thermal
// truth exactly (noise-free), extrapolation flagged.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/thermal_model.h"
#include "io/thermal_file.h"
#include "tests/calibration/test_indirect_plan_loader.h"
#include "tests/thermal/thermal_sim.h"

namespace imubench::io {
namespace {

namespace m = calib::model;

ThermalFile exampleFile() {
  ThermalFile f;
  f.imu_serial = "IMU-42";
  f.coefficients = calib::testing::cubicThermalTruth();
  f.coefficients.accel[4].sigma_poly = {1e-5, 2e-7, 3e-9, 4e-11, 0.0};
  f.coefficients.accel[4].sigma_dTdt = 0.01;
  f.coefficients.gyro[7].order = 4;
  f.coefficients.gyro[7].poly[4] = -3.25e-12;
  return f;
}

void expectSame(const m::ThermalCoefficient& a, const m::ThermalCoefficient& b,
                const std::string& what) {
  EXPECT_EQ(a.order, b.order) << what;
  EXPECT_EQ(a.hysteresis, b.hysteresis) << what;
  EXPECT_EQ(a.dTdt, b.dTdt) << what;
  EXPECT_EQ(a.sigma_dTdt, b.sigma_dTdt) << what;
  for (int k = 0; k <= a.order; ++k) {
    EXPECT_EQ(a.poly[k], b.poly[k]) << what << " c" << k;
    EXPECT_EQ(a.sigma_poly[k], b.sigma_poly[k]) << what << " sigma c" << k;
  }
}

std::filesystem::path tempDir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() /
                 ("imubench_thermal_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

TEST(ThermalFile, JsonRoundTripIsExact) {
  const ThermalFile f = exampleFile();
  const auto path = (tempDir("rt") / "comp.json").string();
  ASSERT_TRUE(writeThermalFile(path, f).ok);
  const ThermalFileResult r = readThermalFile(path);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.value.imu_serial, "IMU-42");
  EXPECT_EQ(r.value.coefficients.t_ref_c, f.coefficients.t_ref_c);
  EXPECT_EQ(r.value.coefficients.t_min_c, f.coefficients.t_min_c);
  EXPECT_EQ(r.value.coefficients.t_max_c, f.coefficients.t_max_c);
  for (int i = 0; i < m::kTriadSize; ++i) {
    expectSame(r.value.coefficients.accel[i], f.coefficients.accel[i],
               "accel " + std::to_string(i));
    expectSame(r.value.coefficients.gyro[i], f.coefficients.gyro[i], "gyro " + std::to_string(i));
  }
  // The interchange shape: misalignments by name, biases with dTdt, scales without.
  const nlohmann::json j = toJson(f);
  EXPECT_EQ(j["format"], "imubench-thermal/1");
  EXPECT_EQ(j["gyro"]["misalignment"]["xz"]["poly"].size(), 5u);
  EXPECT_TRUE(j["accel"]["bias"][1].contains("dTdt"));
  EXPECT_FALSE(j["accel"]["scale"][1].contains("dTdt"));
}

TEST(ThermalFile, CsvHasOneRowPerCoefficientWithEmptyUnusedOrders) {
  const auto path = (tempDir("csv") / "comp.csv").string();
  ASSERT_TRUE(writeThermalCsv(path, exampleFile()).ok);
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "triad,coefficient,axis,c0,c1,c2,c3,c4,dTdt,tmin,tmax");
  int rows = 0;
  std::string accel_bias_y, accel_scale_x;
  while (std::getline(in, line)) {
    ++rows;
    if (line.rfind("accel,bias,y,", 0) == 0) accel_bias_y = line;
    if (line.rfind("accel,scale,x,", 0) == 0) accel_scale_x = line;
  }
  EXPECT_EQ(rows, 24);
  EXPECT_NE(accel_scale_x.find(",,,-50,70"), std::string::npos) << accel_scale_x;  // c4, dTdt empty
  // Cubic with hysteresis: c4 empty, dTdt given.
  std::vector<std::string> f;
  std::stringstream ss(accel_bias_y);
  for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
  ASSERT_EQ(f.size(), 11u) << accel_bias_y;
  EXPECT_FALSE(f[6].empty());
  EXPECT_TRUE(f[7].empty());
  EXPECT_FALSE(f[8].empty());
}

TEST(ThermalFile, RefusalsNameTheFileAndThePath) {
  const auto dir = tempDir("bad");
  nlohmann::json j = toJson(exampleFile());
  j["accel"]["bias"][2]["poly"] = nlohmann::json::array({1, 2, 3, 4, 5, 6});
  std::ofstream((dir / "a.json").string()) << j.dump();
  const auto r = readThermalFile((dir / "a.json").string());
  ASSERT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("a.json: accel.bias[2].poly"), std::string::npos)
      << r.status.message;
  j = toJson(exampleFile());
  j["format"] = "imubench-csv/1";
  std::ofstream((dir / "b.json").string()) << j.dump();
  EXPECT_NE(readThermalFile((dir / "b.json").string()).status.message.find("b.json: format"),
            std::string::npos);
  std::ofstream((dir / "c.json").string()) << "{\n\"format\": ,\n}";
  EXPECT_NE(readThermalFile((dir / "c.json").string()).status.message.find("c.json:2"),
            std::string::npos);
}

// Noise-free: the compensation with the truth itself gives the ideal sensor's increments, for
// a ramping temperature (hysteresis active) and outside the range (flagged, edge values).
TEST(ThermalApply, UndoesTheSimulatorsThermalTruthAndFlagsExtrapolation) {
  const m::ThermalCoefficients truth = calib::testing::cubicThermalTruth();
  calib::Motion motion = calib::testing::libraryMotion("direct_two_axis");
  // Centred past the truth's upper end so the first 400 s cross it.
  motion.temperature =
      calib::testing::rampKnots(truth.t_max_c + 7.0, 0.01, motion.duration, {300.0, 600.0});
  const double end = 400.0;
  const auto run =
      calib::testing::simulateThermal(motion, &truth, calib::NoiseModel::none(), 20.0, 1, end);
  const auto ideal =
      calib::testing::simulateThermal(motion, nullptr, calib::NoiseModel::none(), 20.0, 1, end);
  const calib::ThermalApplyResult r = calib::applyThermal(truth, run.imu);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  std::size_t above = 0;
  double worst_a = 0.0, worst_g = 0.0;
  for (std::size_t k = 0; k < run.imu.size(); ++k) {
    const bool out = run.imu[k].temp_c > truth.t_max_c;
    above += out ? 1 : 0;
    EXPECT_EQ(r.extrapolated[k], out) << k;
    // Rates from a 60 s window match the knots' slope except near the start of the record.
    if (out || run.imu[k].t < 40.0) continue;
    worst_a = std::max(worst_a, (r.compensated[k].dvel - ideal.imu[k].dvel).norm() * 20.0);
    worst_g = std::max(worst_g, (r.compensated[k].dtheta - ideal.imu[k].dtheta).norm() * 20.0);
  }
  EXPECT_GT(above, 0u);
  EXPECT_LT(above, run.imu.size());
  EXPECT_EQ(r.extrapolated_count, above);
  EXPECT_LT(worst_a, 1e-6);   // m/s^2 (the effects are ~1e-2)
  EXPECT_LT(worst_g, 1e-10);  // rad/s (the effects are ~1e-6)
}

}  // namespace
}  // namespace imubench::io
