// imubench experiment validation [--benches N] [--seed S] [--out DIR] [--rate HZ]
//
// The seed paper's validation experiment (calib/indirect/validation_experiment.h): N random
// simulated benches (table errors 10-60 arcsec, navigation-grade sensors), each calibrated directly
// (0), refined on the two-axis 12-run plan (2) and on the three-axis plan (3), then navigated
// through the 8-heading validation with each coefficient set. Prints per bench and aggregate
// the normalised maxima of eqs. 2-3 and the mean total position error S relative to the
// direct solution; --out DIR writes per-bench SVG plots of the three S curves, the curves as
// CSV and a summary JSON. The plans come from the bundled library (plans/library/).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "calib/indirect/validation_experiment.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

struct ExperimentOptions {
  int benches = 20;
  std::uint64_t seed = 1;
  std::string out;
  double rate_hz = 100.0;
  std::string alignment = "gyrocompass";
  bool noise_free_calibration = false;
};

calib::Motion planMotionOrFail(const std::string& file) {
  const std::string path = bundledPlanPath(file);
  if (path.empty()) throw CommandFailed("bundled plan " + file + " not found");
  io::Diagnostics diag(path);
  auto plan = plans::loadPlanFile(path, diag);
  if (!plan || !plans::validatePlan(*plan, diag)) throw CommandFailed(diag.str());
  plans::ExpandResult e = plans::expand(*plan);
  if (!e.status.ok) throw CommandFailed(path + ": " + e.status.message);
  return std::move(e.motion);
}

void writeFileOrFail(const std::filesystem::path& p, const std::string& text) {
  std::ofstream f(p);
  if (!f) throw CommandFailed(p.string() + ": cannot create");
  f << text;
  if (!f) throw CommandFailed(p.string() + ": write error");
}

std::string curvesCsv(const calib::ValidationBench& b) {
  std::string s = "t";
  for (const char* set : {"direct", "two_axis", "three_axis"}) {
    for (const char* q : {"v_E", "v_N", "s_E", "s_N"}) s += std::string(",") + q + "_" + set;
  }
  s += "\n";
  char buf[64];
  for (std::size_t k = 0; k < b.curve[0].t.size(); ++k) {
    std::snprintf(buf, sizeof(buf), "%.3f", b.curve[0].t[k]);
    s += buf;
    for (int i = 0; i < calib::kSetCount; ++i) {
      const calib::NavErrorCurve& c = b.curve[i];
      if (k >= c.t.size()) {
        s += ",,,,";
        continue;
      }
      std::snprintf(buf, sizeof(buf), ",%.6g,%.6g,%.6g,%.6g", c.v_E[k], c.v_N[k], c.s_E[k],
                    c.s_N[k]);
      s += buf;
    }
    s += "\n";
  }
  return s;
}

void runValidation(const ExperimentOptions& o) {
  if (o.benches < 1) throw CommandFailed("--benches must be >= 1", 2);
  calib::ValidationMotions m;
  m.direct = planMotionOrFail("direct_two_axis.toml");
  m.direct_three_axis = planMotionOrFail("direct_three_axis.toml");
  m.two_axis_runs = planMotionOrFail("two_axis_12run.toml");
  m.three_axis_runs = planMotionOrFail("three_axis_indirect.toml");
  m.validation = planMotionOrFail("validation_8heading.toml");
  calib::ValidationOptions vo;
  vo.imu_rate_hz = o.rate_hz;
  vo.alignment = o.alignment == "table-heading" ? calib::ValidationAlignment::kTableHeading
                                                : calib::ValidationAlignment::kGyrocompass;
  if (o.noise_free_calibration) {
    vo.gyro_arw_deg_sqrt_h = 0.0;
    vo.accel_noise_ug_sqrt_hz = 0.0;
  }
  std::string why;
  if (!vo.IsValid(&why)) throw CommandFailed("options: " + why, 2);
  if (!o.out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.out, ec);
    if (ec) throw CommandFailed(o.out + ": " + ec.message());
  }
  std::printf(
      "validation experiment: %d benches, seeds %llu..%llu, IMU %.0f Hz (calibration runs %s, "
      "validation noise-free), 8 headings x 15 min, alignment: %s\n",
      o.benches, static_cast<unsigned long long>(o.seed),
      static_cast<unsigned long long>(o.seed + static_cast<std::uint64_t>(o.benches) - 1),
      o.rate_hz, o.noise_free_calibration ? "noise-free" : "with nav-grade noise",
      o.alignment == "table-heading" ? "levelled, heading from the table setting"
                                     : "levelling + gyrocompassing with each set");
  std::printf(
      "normalised by the direct solution's maxima (eqs. 2-3); S = mean sqrt(dS_E^2 + dS_N^2)\n");
  std::printf("%6s | %-22s | %7s %7s %7s %7s | %7s | %8s | %s\n", "seed", "coefficients", "dV_E",
              "dV_N", "dS_E", "dS_N", "S mean", "S ratio", "tilt est (arcsec)");
  std::vector<calib::ValidationBench> benches;
  nlohmann::json summary = nlohmann::json::array();
  for (int n = 0; n < o.benches; ++n) {
    const std::uint64_t seed = o.seed + static_cast<std::uint64_t>(n);
    calib::ValidationBench b = calib::runValidationBench(m, seed, vo);
    if (!b.status.ok) {
      std::printf("%6llu | FAILED: %s\n", static_cast<unsigned long long>(seed),
                  b.status.message.c_str());
      benches.push_back(std::move(b));
      continue;
    }
    for (int i = 0; i < calib::kSetCount; ++i) {
      std::printf("%6llu | %-22s | %7.3f %7.3f %7.3f %7.3f | %7.3f | %7.1f%% | %+6.1f %+6.1f\n",
                  static_cast<unsigned long long>(seed),
                  calib::coefficientSetName(static_cast<calib::CoefficientSet>(i)), b.max_v_E[i],
                  b.max_v_N[i], b.max_s_E[i], b.max_s_N[i], b.mean_S[i], 100.0 * b.ratio[i],
                  b.base_tilt_estimate[i].x() * kRadToArcsec,
                  b.base_tilt_estimate[i].y() * kRadToArcsec);
    }
    // What the refinements estimate: the base tilt, plus the two-axis outer encoder zero
    // (a tilt about the outer axis, calib/indirect/indirect_calibration.h).
    const Vec2 tilt2 =
        calib::toGyroReferenced(b.truth_two_axis, {calib::TableKind::kTwoAxis, kPi / 2.0})
            .base_tilt;
    const Vec2 tilt3 = b.truth_three_axis.table.base_tilt;
    std::printf(
        "%6s | true tilt (+ outer encoder zero) %+6.1f %+6.1f arcsec (two-axis), %+6.1f %+6.1f "
        "(three-axis)\n",
        "", tilt2.x() * kRadToArcsec, tilt2.y() * kRadToArcsec, tilt3.x() * kRadToArcsec,
        tilt3.y() * kRadToArcsec);
    std::fflush(stdout);
    summary.push_back({{"seed", seed},
                       {"ratio_two_axis", b.ratio[1]},
                       {"ratio_three_axis", b.ratio[2]},
                       {"mean_S", {b.mean_S[0], b.mean_S[1], b.mean_S[2]}}});
    if (!o.out.empty()) {
      const std::filesystem::path dir(o.out);
      const std::string stem = "bench_" + std::to_string(seed);
      writeFileOrFail(dir / (stem + ".svg"), calib::positionErrorSvg(b));
      writeFileOrFail(dir / (stem + ".csv"), curvesCsv(b));
    }
    benches.push_back(std::move(b));
  }
  const calib::ValidationAggregate a = calib::aggregate(benches);
  std::printf("aggregate over %d benches: refined / direct mean position error S:\n", a.benches);
  for (int i = 1; i < calib::kSetCount; ++i) {
    std::printf(
        "  %-22s mean %5.1f %%  median %5.1f %%  worst %5.1f %%  benches <= 20 %%: %d/%d  "
        "(target: mean <= 20 %%; the paper: %s)\n",
        calib::coefficientSetName(static_cast<calib::CoefficientSet>(i)), 100.0 * a.mean_ratio[i],
        100.0 * a.median_ratio[i], 100.0 * a.worst_ratio[i], a.within_target[i], a.benches,
        i == 1 ? "62.4 %" : "56.5 %");
  }
  if (!o.out.empty()) {
    nlohmann::json j;
    j["benches"] = summary;
    j["mean_ratio_two_axis"] = a.mean_ratio[1];
    j["mean_ratio_three_axis"] = a.mean_ratio[2];
    j["worst_ratio_two_axis"] = a.worst_ratio[1];
    j["worst_ratio_three_axis"] = a.worst_ratio[2];
    j["median_ratio_two_axis"] = a.median_ratio[1];
    j["median_ratio_three_axis"] = a.median_ratio[2];
    j["alignment"] = o.alignment;
    j["noise_free_calibration"] = o.noise_free_calibration;
    writeFileOrFail(std::filesystem::path(o.out) / "summary.json", j.dump(2) + "\n");
    std::printf("plots, curves and summary written to %s\n", o.out.c_str());
  }
  if (a.benches != o.benches) throw CommandFailed("some benches failed (see above)");
}

}  // namespace

void addExperimentCommand(CLI::App& app) {
  CLI::App* exp = app.add_subcommand("experiment", "Reproduce the seed paper's experiments");
  exp->require_subcommand(1);
  auto opt = std::make_shared<ExperimentOptions>();
  CLI::App* val = exp->add_subcommand(
      "validation", "Direct vs navigation-based calibration, 8-heading free navigation");
  val->add_option("--benches", opt->benches, "Number of random benches (default 20)");
  val->add_option("--seed", opt->seed, "Seed of the first bench (default 1)");
  val->add_option("--out", opt->out, "Directory for SVG plots, CSV curves and summary.json");
  val->add_option("--rate", opt->rate_hz, "IMU rate of the simulations, Hz (default 100)");
  val->add_option("--alignment", opt->alignment,
                  "Initial attitude of the validation navigation: gyrocompass (default; levelling "
                  "and gyrocompassing with each coefficient set) or table-heading (levelling, "
                  "heading from the table setting)")
      ->check(CLI::IsMember({"gyrocompass", "table-heading"}));
  val->add_flag("--noise-free-calibration", opt->noise_free_calibration,
                "Simulate the calibration runs without sensor noise (shows what is left when "
                "only the model, not the noise, limits the refinement)");
  val->callback([opt] { runValidation(*opt); });
}

}  // namespace imubench::tools
