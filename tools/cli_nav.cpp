// imubench nav DIR [--out FILE] [--every SECONDS]: free (unaided) navigation of a recording.
// Initial state: at rest at the recording's site, attitude from the table's encoder angles at
// the start through the nominal table kinematics (the seed's validation: no alignment, no
// aiding). Prints E/N velocity errors and displacements over time.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

#include "calib/table_model.h"
#include "io/recording.h"
#include "nav/free_navigation.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

struct NavOptions {
  std::string dir;
  std::string out;
  double every_s = 60.0;
};

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

  calib::TableGeometry geometry;
  geometry.kind = rec.table_kind;
  geometry.outer_axis_heading_rad = rec.outerAxisHeadingDeg() * kDegToRad;
  const calib::TableModel table(geometry, calib::TableErrors{});
  if (rec.table.empty())
    throw CommandFailed(o.dir + ": no table angles (table.csv has no rows): no start attitude");
  const std::vector<double> start_angles = io::tableAnglesRad(rec.table_kind, rec.table.front());
  const Mat3 C_LB =
      table.nominalC_LB(calib::tableAnglesFromAxes(rec.table_kind, start_angles.data()));

  const double t0 = nav::firstIntervalStart(rec.imu);
  const nav::NavState initial = nav::stationaryState(t0, Quat(C_LB).normalized(), rec.site());
  nav::FreeNavOptions opt;
  opt.output_interval_s = o.every_s;
  opt.mech.gravity_mps2 = rec.gravity_mps2;
  std::string why;
  if (!opt.IsValid(&why)) throw CommandFailed("navigation options: " + why);
  const nav::FreeNavResult r = nav::navigateFree(initial, rec.imu, opt);

  std::cout << "free navigation of " << o.dir << ": " << r.samples_used << " of " << rec.imu.size()
            << " samples, start attitude from table angles at t = " << rec.table.front().t
            << " s\n";
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
  sub->callback([opt] { runNav(*opt); });
}

}  // namespace imubench::tools
