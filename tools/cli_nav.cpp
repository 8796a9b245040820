// imubench nav DIR [--out FILE] [--every SECONDS] [--align SECONDS]: free (unaided) navigation
// of a recording. Initial state: at rest at the recording's site, attitude from the table's
// encoder angles at the start through the nominal table kinematics (the seed's validation: no
// alignment, no aiding), or with --align from a static coarse alignment (levelling and
// gyrocompassing, nav/alignment.h) over the first SECONDS: heading, the latitude the Earth rate
// implies, the biases a static span separates and the alignment's own uncertainty
// (nav/alignment_uncertainty.h) are printed; a span that is not static is refused (exit 3).
// Warns when the start is not static. Prints E/N velocity errors and displacements over time.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

#include "calib/table_model.h"
#include "io/recording.h"
#include "nav/alignment_uncertainty.h"
#include "nav/free_navigation.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

struct NavOptions {
  std::string dir;
  std::string out;
  double every_s = 60.0;
  double align_s = 0.0;  // > 0: align over the first align_s seconds instead of table angles
};

// The samples of the first `seconds` of the recording.
std::span<const nav::ImuSample> firstSeconds(const nav::ImuSamples& imu, double seconds) {
  const double t_end = nav::firstIntervalStart(imu) + seconds;
  std::size_t n = 0;
  while (n < imu.size() && imu[n].t <= t_end) ++n;
  return {imu.data(), n};
}

// Static coarse alignment over the first o.align_s seconds, its report printed; refused
// (exit 3) when the span is not static or the Earth rate cannot give a heading.
Quat alignedStart(const NavOptions& o, const io::Recording& rec) {
  const auto span = firstSeconds(rec.imu, o.align_s);
  const nav::AlignmentResult a = nav::coarseAlign(span, rec.site());
  if (!a.ok())
    throw CommandFailed(o.dir + ": alignment over the first " + std::to_string(o.align_s) +
                            " s refused: " + a.message +
                            " (a static start is needed: levelling and gyrocompassing from a "
                            "moving or swaying IMU are not built; a MEMS gyro bias far above the "
                            "Earth rate gives no heading)",
                        kExitResultUnusable);
  const nav::AlignmentUncertainty u = nav::alignmentUncertainty(span, rec.site(), a);
  const Vec3 rph = nav::rollPitchHeading(a.q_BtoL) / kDegToRad;
  std::printf(
      "alignment over %.3g s (%d samples): roll %.4f deg, pitch %.4f deg, heading %.4f deg\n",
      a.duration_s, u.samples, rph[0], rph[1], rph[2]);
  std::printf(
      "  1-sigma from the noise: tilt %.3g deg, heading %.3g deg; a residual East gyro bias "
      "b adds b / (W cos lat) = %.3g deg of heading per 0.01 deg/h\n",
      u.sigma_tilt_rad / kDegToRad, u.sigma_heading_rad / kDegToRad,
      u.heading_rad_per_gyro_bias * 0.01 * kDegToRad / 3600.0 / kDegToRad);
  std::printf("  latitude the Earth rate implies: %.3f +- %.3f deg (site %.3f deg)\n",
              u.implied_latitude_rad / kDegToRad, u.sigma_implied_latitude_rad / kDegToRad,
              rec.latitude_deg);
  std::printf(
      "  biases a static span separates: vertical gyro %.3g deg/h, vertical accelerometer "
      "%.3g m/s^2 (horizontal ones are inseparable from the tilt and heading)\n",
      u.gyro_bias_up_radps / kDegToRad * 3600.0, u.accel_bias_up_mps2);
  return a.q_BtoL;
}

// Warns (stderr) when the first seconds are not static: a start attitude from table angles
// or an alignment assumes the IMU at rest there.
void warnIfStartMoves(const NavOptions& o, const io::Recording& rec) {
  const nav::AlignmentResult a = nav::coarseAlign(firstSeconds(rec.imu, 10.0), rec.site());
  if (a.status == nav::AlignmentStatus::kNotStatic)
    std::cerr << "imubench: warning: " << o.dir << ": the IMU is not static in the first 10 s ("
              << a.message << "); navigation assumes it at rest at the start\n";
}

std::string fmt(const char* f, double a, double b, double c, double d, double e) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), f, a, b, c, d, e);
  return buf;
}

void runNav(const NavOptions& o) {
  const auto read = io::readRecording(o.dir);
  if (!read.status.ok) throw CommandFailed(read.status.message);
  const io::Recording& rec = read.value;
  if (rec.imu.size() < 2) throw CommandFailed(o.dir + ": fewer than two IMU samples");

  warnIfStartMoves(o, rec);
  Quat q_BtoL;
  if (o.align_s > 0.0) {
    q_BtoL = alignedStart(o, rec);
  } else {
    if (rec.table.empty())
      throw CommandFailed(o.dir +
                          ": no table angles (table.csv has no rows): give --align SECONDS");
    calib::TableGeometry geometry;
    geometry.kind = rec.table_kind;
    geometry.outer_axis_heading_rad = rec.outerAxisHeadingDeg() * kDegToRad;
    const calib::TableModel table(geometry, calib::TableErrors{});
    const std::vector<double> start_angles = io::tableAnglesRad(rec.table_kind, rec.table.front());
    q_BtoL =
        Quat(table.nominalC_LB(calib::tableAnglesFromAxes(rec.table_kind, start_angles.data())));
  }

  const double t0 = nav::firstIntervalStart(rec.imu);
  const nav::NavState initial = nav::stationaryState(t0, q_BtoL.normalized(), rec.site());
  nav::FreeNavOptions opt;
  opt.output_interval_s = o.every_s;
  opt.mech.gravity_mps2 = rec.gravity_mps2;
  std::string why;
  if (!opt.IsValid(&why)) throw CommandFailed("navigation options: " + why);
  const nav::FreeNavResult r = nav::navigateFree(initial, rec.imu, opt);

  std::cout << "free navigation of " << o.dir << ": " << r.samples_used << " of " << rec.imu.size()
            << " samples, start attitude "
            << (o.align_s > 0.0 ? "from the alignment" : "from table angles at the start") << "\n";
  std::cout << "       t (s)   vE err (m/s)   vN err (m/s)      dE (m)      dN (m)\n";
  double max_s = 0.0;
  for (const auto& p : r.series) {
    std::cout << fmt("%12.1f %14.6f %14.6f %11.3f %11.3f\n", p.t, p.v_E_err, p.v_N_err, p.d_E_m,
                     p.d_N_m);
    max_s = std::max(max_s, std::hypot(p.d_E_m, p.d_N_m));
  }
  std::cout << "max horizontal position error: " << max_s << " m\n";
  if (!o.out.empty()) {
    std::ofstream f(o.out);
    if (!f) throw CommandFailed(o.out + ": cannot create");
    f.precision(17);
    f << "t,v_E_err,v_N_err,d_E,d_N\n";
    for (const auto& p : r.series) {
      f << p.t << ',' << p.v_E_err << ',' << p.v_N_err << ',' << p.d_E_m << ',' << p.d_N_m << '\n';
    }
    if (!f) throw CommandFailed(o.out + ": write error");
  }
  if (!r.ok()) {
    throw CommandFailed(o.dir + ": navigation stopped (" + nav::freeNavStatusName(r.status) +
                        "): " + r.message);
  }
}

}  // namespace

void addNavCommand(CLI::App& app) {
  auto opt = std::make_shared<NavOptions>();
  CLI::App* sub = app.add_subcommand("nav", "free (unaided) navigation of a recording");
  sub->add_option("dir", opt->dir, "imubench-csv/1 recording directory")->required();
  sub->add_option("--out", opt->out, "write the error series as CSV (t,v_E_err,v_N_err,d_E,d_N)");
  sub->add_option("--every", opt->every_s, "output interval, s")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--align", opt->align_s,
                  "static coarse alignment over the first SECONDS (no table angles needed)")
      ->check(CLI::PositiveNumber);
  sub->callback([opt] { runNav(*opt); });
}

}  // namespace imubench::tools
