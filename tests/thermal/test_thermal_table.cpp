// The joint thermal fit on a table with geometric errors (issue 26 item 2): the bundled direct
// plan at three soak points on a two-axis table with 20-60 arcsec on every geometric term.
//   - the observable table errors (base tilt, the outer encoder zero in its x component) are
//     estimated within 3 arcsec beside the polynomials and the fit is usable at the noise floor;
//     mounting and the inner encoder zero are held with their reason (the misalignments absorb
//     them);
//   - the same rows with the table taken as perfect are refused (kUnusable, a triad's
//     normalised residual named); with the true table given they are usable.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "calib/thermal/thermal_fit.h"
#include "tests/calibration/test_indirect_plan_loader.h"
#include "tests/thermal/thermal_sim.h"

namespace imubench::calib {
namespace {

using testing::cubicThermalTruth;
using testing::libraryMotion;
using testing::rampKnots;
using testing::simulateThermal;

constexpr double kArcsec = kPi / (180.0 * 3600.0);
const model::ThermalLag kLag{300.0, 600.0};

TableErrors tableErrors() {
  TableErrors e;
  e.base_tilt = Vec2(35.0, -48.0) * kArcsec;
  e.nonorthogonality.inner_y = 52.0 * kArcsec;
  e.mounting = Vec2(-41.0, 24.0) * kArcsec;
  e.encoder_zero.outer = 27.0 * kArcsec;
  e.encoder_zero.inner = -33.0 * kArcsec;
  return e;
}

const std::vector<ThermalRun>& runs() {
  static const std::vector<ThermalRun> r = [] {
    std::vector<ThermalRun> out;
    const model::ThermalCoefficients truth = cubicThermalTruth();
    Motion motion = libraryMotion("direct_two_axis");
    std::uint64_t seed = 300;
    for (const double T : {-20.0, 0.0, 20.0, 40.0, 60.0}) {
      motion.temperature = rampKnots(T, 1e-4, motion.duration, kLag);
      out.push_back({simulateThermal(motion, &truth, NoiseModel::navigationGrade(), 20.0, ++seed,
                                     0.0, tableErrors()),
                     "T" + std::to_string(static_cast<int>(T))});
    }
    return out;
  }();
  return r;
}

double tableValue(const ThermalRunsFitResult& f, const std::string& name) {
  return flatValue(f.table.values, name).value_or(0.0);
}

TEST(ThermalTable, ObservableTableErrorsEstimatedAndUsable) {
  const ThermalRunsFitResult f = fitThermalJoint(runs());
  ASSERT_TRUE(f.status.HasResult()) << f.status.message;
  EXPECT_TRUE(f.status.IsSolutionUsable()) << f.status.message;
  const TableErrors e = tableErrors();
  // The outer encoder zero is a tilt about the outer axis (East): in base_tilt.x.
  EXPECT_NEAR(tableValue(f, "table.base_tilt.x"), e.base_tilt.x() + e.encoder_zero.outer,
              3.0 * kArcsec);
  EXPECT_NEAR(tableValue(f, "table.base_tilt.y"), e.base_tilt.y(), 3.0 * kArcsec);
  for (const char* held : {"table.mounting.x", "table.mounting.y", "table.encoder_zero.outer",
                           "table.encoder_zero.inner"}) {
    const auto it = f.table.uncertainty.find(held);
    ASSERT_NE(it, f.table.uncertainty.end()) << held;
    EXPECT_FALSE(it->second.observable) << held;
    EXPECT_EQ(tableValue(f, held), 0.0) << held;
  }
  bool mounting_reason = false;
  for (const std::string& n : f.notes) {
    mounting_reason = mounting_reason || (n.find("table.mounting.x") != std::string::npos &&
                                          n.find("misalignments absorb") != std::string::npos);
  }
  EXPECT_TRUE(mounting_reason) << "no reason for holding the mounting";
  EXPECT_LT(f.accel_normalised_rms, 1.5);
  EXPECT_LT(f.gyro_normalised_rms, 1.5);
}

TEST(ThermalTable, PerfectTableTakenIsRefused) {
  ThermalJointFitOptions o;
  o.estimate_table = false;
  const ThermalRunsFitResult f = fitThermalJoint(runs(), o);
  ASSERT_TRUE(f.status.HasResult()) << f.status.message;
  EXPECT_EQ(f.status.code, FitStatusCode::kUnusable);
  EXPECT_NE(f.status.message.find("normalised residual RMS"), std::string::npos)
      << f.status.message;
  EXPECT_FALSE(f.status.largest_residuals.empty());
}

TEST(ThermalTable, TrueTableGivenIsUsable) {
  ThermalJointFitOptions o;
  o.estimate_table = false;
  o.direct.known_table_errors = tableErrors();
  const ThermalRunsFitResult f = fitThermalJoint(runs(), o);
  EXPECT_TRUE(f.status.IsSolutionUsable()) << f.status.message;
}

}  // namespace
}  // namespace imubench::calib
