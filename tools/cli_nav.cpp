// imubench nav DIR [--out FILE] [--every SECONDS] [--align SECONDS]: free (unaided) navigation
// of a recording. Initial state: at rest at the recording's site, attitude from the table's
// encoder angles at the start through the nominal table kinematics (the seed's validation: no
// alignment, no aiding), or with --align from a coarse alignment over the first SECONDS:
// through sway for 60 s or more (nav/inertial_alignment.h), static for shorter spans
// (nav/alignment.h, nav/alignment_uncertainty.h). Heading, the latitude the Earth rate implies,
// the biases the span separates and the alignment's own uncertainty are printed; a span that
// cannot be aligned is refused (exit 3) with the reason, with levelling only when the gyro's
// bias hides the Earth rate. Warns when the start is not static. Prints E/N velocity errors
// and displacements over time.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

#include "calib/table_model.h"
#include "io/recording.h"
#include "nav/alignment_uncertainty.h"
#include "nav/free_navigation.h"
#include "nav/inertial_alignment.h"
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

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0, double e = 0) {
  char buf[640];
  std::snprintf(buf, sizeof(buf), f, a, b, c, d, e);
  return buf;
}

// The span's mean specific force and angular rate (B).
struct SpanMeans {
  Vec3 f_B = Vec3::Zero();
  Vec3 w_B = Vec3::Zero();
};
SpanMeans spanMeans(std::span<const nav::ImuSample> span) {
  SpanMeans m;
  for (const nav::ImuSample& x : span) {
    m.f_B += x.dvel;
    m.w_B += x.dtheta;
  }
  const double dt = span.back().t - nav::firstIntervalStart(span);
  m.f_B /= dt;
  m.w_B /= dt;
  return m;
}

// When the span is at rest on average (|mean f| within 2 % of gravity) but its mean rate is
// far above the Earth rate (3x, the static alignment's own limit), no span can give a heading:
// the gyro's bias hides the Earth rate (told from sway by a rate that is steady over the span's
// quarters). Returns the reason then (and prints the levelling: roll
// and pitch from the mean specific force, nav/alignment.h convention
// C_LB = Rz(-h) Rx(p) Ry(r), so f_B = g (-cos p sin r, sin p, cos p cos r)); empty otherwise.
std::string gyroHidesEarthRate(const io::Recording& rec, std::span<const nav::ImuSample> span) {
  const SpanMeans m = spanMeans(span);
  const double g = nav::siteGravity(rec.site()), w = m.w_B.norm();
  if (std::abs(m.f_B.norm() - g) > 0.02 * g || !(w > 3.0 * nav::kEarthRate)) return "";
  // A steady rate (a bias), not sway: each quarter's mean rate within half the mean's size.
  constexpr std::size_t kQuarters = 4;
  if (span.size() < 2 * kQuarters) return "";
  const std::size_t q = span.size() / kQuarters;
  for (std::size_t i = 0; i < kQuarters; ++i) {
    const SpanMeans mq = spanMeans(span.subspan(i * q, q));
    if ((mq.w_B - m.w_B).norm() > 0.5 * w) return "";
  }
  const Vec3& f = m.f_B;
  std::printf("levelling only (mean specific force %.4f m/s^2): roll %.4f deg, pitch %.4f deg\n",
              f.norm(), std::atan2(-f.x(), f.z()) / kDegToRad,
              std::asin(std::clamp(f.y() / f.norm(), -1.0, 1.0)) / kDegToRad);
  return fmt(
      "the gyros' mean rate over the span is %.4g deg/h, %.3g times the Earth rate (15 "
      "deg/h at most): a gyro bias that large (a consumer MEMS gyro's) hides the Earth "
      "rate, and heading needs it: a gyro like this cannot gyrocompass. Roll and pitch "
      "above are levelling only; no navigation without a heading",
      w / kDegPerHourToRadPerSec, w / nav::kEarthRate);
}

// A refusal of the alignment: exit 3 with the reason, and the levelling where only the heading
// is out of reach.
[[noreturn]] void refuseAlignment(const NavOptions& o, const io::Recording& rec,
                                  std::span<const nav::ImuSample> span, const std::string& why) {
  const std::string gyro = span.size() >= 2 ? gyroHidesEarthRate(rec, span) : "";
  throw CommandFailed(
      o.dir + ": alignment over the first " + fmt("%.3g", o.align_s) + " s refused: " +
          (gyro.empty() ? why + " (the IMU must be at rest, or sway about a point at rest, "
                                "over the span)"
                        : gyro + " (" + why + ")"),
      kExitResultUnusable);
}

// Static coarse alignment over the first o.align_s seconds, its report printed.
Quat staticStart(const io::Recording& rec, const nav::AlignmentResult& a,
                 std::span<const nav::ImuSample> span) {
  const nav::AlignmentUncertainty u = nav::alignmentUncertainty(span, rec.site(), a);
  const Vec3 rph = nav::rollPitchHeading(a.q_BtoL) / kDegToRad;
  std::printf(
      "static alignment over %.3g s (%d samples): roll %.4f deg, pitch %.4f deg, heading %.4f "
      "deg\n",
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

// Sway-tolerant alignment (nav/inertial_alignment.h) over the span, its report printed; the
// attitude at the span's start is returned (navigation starts there).
Quat swayStart(const NavOptions& o, const io::Recording& rec,
               std::span<const nav::ImuSample> span) {
  const nav::InertialAlignmentResult a = nav::inertialAlign(span, rec.site());
  if (!a.ok()) refuseAlignment(o, rec, span, a.message);
  const Vec3 rph = nav::rollPitchHeading(a.q_BtoL_start) / kDegToRad;
  std::printf(
      "sway-tolerant alignment (gravity in the inertial frame) over %.3g s (%d samples, %d "
      "blocks, attitude moved up to %.3g deg): roll %.4f deg, pitch %.4f deg, heading %.4f "
      "deg\n",
      a.duration_s, a.samples, a.blocks, a.sway_peak_rad / kDegToRad, rph[0], rph[1], rph[2]);
  std::printf(
      "  1-sigma from the fit's residuals: tilt %.3g deg, heading %.3g deg; a residual East "
      "gyro bias b adds b / (W cos lat) = %.3g deg of heading per 0.01 deg/h\n",
      a.sigma_tilt_rad / kDegToRad, a.sigma_heading_rad / kDegToRad,
      a.heading_rad_per_gyro_bias * 0.01 * kDegPerHourToRadPerSec / kDegToRad);
  std::printf("  latitude the Earth rate implies: %.3f +- %.3f deg (site %.3f deg)\n",
              a.implied_latitude_rad / kDegToRad, a.sigma_implied_latitude_rad / kDegToRad,
              rec.latitude_deg);
  std::printf(
      "  biases: vertical accelerometer %.3g m/s^2; gyro biases are not separable under sway "
      "(the East one is the heading term above); fit misfit %.3g deg RMS\n",
      a.accel_bias_up_mps2, a.residual_rms_rad / kDegToRad);
  return a.q_BtoL_start;
}

// Alignment over the first o.align_s seconds. A span long enough for the sway-tolerant
// alignment (nav/inertial_alignment.h, 60 s) always takes it, static or not: a static test of
// block means passes a sway whose periods the blocks average, and the static gyrocompass then
// takes the sway's net turn over the span for Earth rate (a ship's 4 deg roll over 290 s is
// 50 deg/h). A shorter span must be static (nav/alignment.h). Refused (exit 3) with the reason.
Quat alignedStart(const NavOptions& o, const io::Recording& rec) {
  const auto span = firstSeconds(rec.imu, o.align_s);
  if (span.size() < 2) refuseAlignment(o, rec, span, "fewer than two samples");
  const double duration = span.back().t - nav::firstIntervalStart(span);
  if (duration >= nav::InertialAlignmentOptions{}.min_duration_s) return swayStart(o, rec, span);
  const nav::AlignmentResult a = nav::coarseAlign(span, rec.site());
  if (!a.ok())
    refuseAlignment(o, rec, span,
                    a.message + (a.status == nav::AlignmentStatus::kNotStatic
                                     ? fmt("; a swaying IMU needs a span of at least %.3g s",
                                           nav::InertialAlignmentOptions{}.min_duration_s)
                                     : std::string()));
  return staticStart(rec, a, span);
}

// Warns (stderr) when the first seconds are not static: a start attitude from table angles
// or an alignment assumes the IMU at rest there.
void warnIfStartMoves(const NavOptions& o, const io::Recording& rec) {
  const nav::AlignmentResult a = nav::coarseAlign(firstSeconds(rec.imu, 10.0), rec.site());
  if (a.status == nav::AlignmentStatus::kNotStatic)
    std::cerr << "imubench: warning: " << o.dir << ": the IMU is not static in the first 10 s ("
              << a.message << "); navigation assumes it at rest at the start\n";
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
                  "coarse alignment over the first SECONDS (no table angles needed): static, "
                  "or through sway (vehicle, ship) when the span is not static")
      ->check(CLI::PositiveNumber);
  sub->callback([opt] { runNav(*opt); });
}

}  // namespace imubench::tools
