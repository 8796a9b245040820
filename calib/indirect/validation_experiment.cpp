#include "calib/indirect/validation_experiment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "calib/indirect/bench_calibration.h"
#include "calib/option_check.h"
#include "calib/simulator.h"
#include "nav/alignment.h"
#include "nav/free_navigation.h"

namespace imubench::calib {

namespace {

SensorModel randomSensors(std::mt19937_64& rng, const ValidationOptions& o) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto sgn = [&] { return u(rng) < 0 ? -1.0 : 1.0; };
  SensorModel s;
  for (TriadModel* t : {&s.accel, &s.gyro}) {
    for (int i = 0; i < 3; ++i) t->scale[i] = 1.0 + o.scale_error_ppm * 1e-6 * u(rng);
    const double m = o.misalignment_arcsec * kArcsecToRad;
    t->mis = {m * u(rng), m * u(rng), m * u(rng), m * u(rng), m * u(rng), m * u(rng)};
  }
  for (int i = 0; i < 3; ++i) {
    s.accel.bias[i] = sgn() * o.accel_bias_ug * kMicroGToMps2;
    s.gyro.bias[i] = sgn() * o.gyro_bias_deg_h * kDegPerHourToRadPerSec;
  }
  return s;
}

TableErrors randomTable(std::mt19937_64& rng, const ValidationOptions& o, TableKind kind) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> mag(o.table_error_min_arcsec, o.table_error_max_arcsec);
  auto err = [&] { return (u(rng) < 0 ? -1.0 : 1.0) * mag(rng) * kArcsecToRad; };
  TableErrors e;
  e.base_tilt = Vec2(err(), err());
  e.mounting = Vec2(err(), err());
  e.encoder_zero.inner = err();
  e.nonorthogonality.inner_y = err();
  // Two-axis: the outer encoder zero acts like a tilt about the outer axis. Three-axis: the
  // middle zero joins nonorthogonality middle_x; the outer zero (a heading offset of the whole
  // table, seen only through the Earth rate) is not in the navigation-based model
  // (docs/calibration.md), so it stays zero here.
  if (kind == TableKind::kTwoAxis) {
    e.encoder_zero.outer = err();
  } else {
    e.nonorthogonality.middle_x = err();
    e.nonorthogonality.middle_y = err();
    e.encoder_zero.middle = err();
  }
  return e;
}

bool simulateRun(const BenchTruth& truth, const Motion& motion, const ValidationOptions& o,
                 bool noise, std::uint64_t seed, Simulation* out, std::string* why) {
  SimulatorInput si;
  si.world.site = o.site;
  si.world.truth = truth;
  if (noise) {
    si.world.noise.gyro.white = o.gyro_arw_deg_sqrt_h * kDegToRad / 60.0;
    si.world.noise.accel.white = o.accel_noise_ug_sqrt_hz * kMicroGToMps2;
  }
  si.motion = motion;
  SimOptions so;
  so.imu_rate_hz = o.imu_rate_hz;
  so.table_rate_hz = o.table_rate_hz;
  so.seed = seed;
  *out = simulate(si, so);
  if (!out->status.ok) *why = out->status.message;
  return out->status.ok;
}

// Compensated increments: dth_c = G_g dth + h_g dt (exact inverse of eq. 1), same for dv.
nav::ImuSamples compensate(const nav::ImuSamples& raw, const SensorModel& c, double t_start) {
  Mat3 Ga, Gg;
  Vec3 ha, hg;
  model::compensationAffine(c.accel.block().data(), &Ga, &ha);
  model::compensationAffine(c.gyro.block().data(), &Gg, &hg);
  nav::ImuSamples out(raw.size());
  double t_prev = t_start;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    const double dt = raw[k].t - t_prev;
    t_prev = raw[k].t;
    out[k] = raw[k];
    out[k].dtheta = Gg * raw[k].dtheta + hg * dt;
    out[k].dvel = Ga * raw[k].dvel + ha * dt;
  }
  return out;
}

bool navigate(const Simulation& sim, const SensorModel& c, const ValidationOptions& o,
              NavErrorCurve* curve, std::string* why) {
  const double t0 = nav::firstIntervalStart(sim.imu);
  const nav::ImuSamples comp = compensate(sim.imu, c, t0);
  std::size_t n_align = 0;
  while (n_align < comp.size() && comp[n_align].t - t0 <= o.levelling_s) ++n_align;
  if (n_align < 2 || sim.table.empty()) {
    *why = "validation recording too short to align";
    return false;
  }
  const std::span<const nav::ImuSample> align_span(comp.data(), n_align);
  Quat q0;
  if (o.alignment == ValidationAlignment::kGyrocompass) {
    // Levelling and gyrocompassing with this coefficient set's own compensated data, as an
    // INS aligns before a navigation test.
    const nav::AlignmentResult a = nav::coarseAlign(align_span, o.site);
    if (!a.ok()) {
      *why = "alignment: " + a.message;
      return false;
    }
    q0 = a.q_BtoL;
  } else {
    // Levelling with this set's accelerometers; heading from the nominal table setting
    // (smallest rotation of the nominal attitude that levels it).
    Vec3 dv = Vec3::Zero();
    for (const nav::ImuSample& s : align_span) dv += s.dvel;
    const TableSample& ts = sim.table.front();
    const Mat3 C_nom =
        TableModel(TableGeometry{sim.kind, kPi / 2.0}, TableErrors{}).nominalC_LB(ts.angles);
    const Vec3 up_nom = (C_nom * dv).normalized();
    q0 = Quat::FromTwoVectors(up_nom, Vec3::UnitZ()) * Quat(C_nom);
  }
  nav::FreeNavOptions fo;
  fo.output_interval_s = o.output_interval_s;
  fo.mech.gravity_mps2 = o.site.gravity_mps2;
  const nav::FreeNavResult r = nav::navigateFree(nav::stationaryState(t0, q0, o.site), comp, fo);
  if (!r.ok()) {
    *why = "navigation failed: " + r.message;
    return false;
  }
  for (const nav::NavErrorPoint& p : r.series) {
    curve->t.push_back(p.t);
    curve->v_E.push_back(p.v_E_err);
    curve->v_N.push_back(p.v_N_err);
    curve->s_E.push_back(p.d_E_m);
    curve->s_N.push_back(p.d_N_m);
  }
  return true;
}

double maxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

const char* coefficientSetName(CoefficientSet s) {
  switch (s) {
    case CoefficientSet::kDirect:
      return "direct (0)";
    case CoefficientSet::kTwoAxisRefined:
      return "two-axis refined (2)";
    case CoefficientSet::kThreeAxisRefined:
      return "three-axis refined (3)";
  }
  return "?";
}

bool ValidationOptions::IsValid(std::string* why) const {
  if (!(imu_rate_hz > 0.0) || !(table_rate_hz > 0.0))
    return invalidOption(why, "rates must be > 0");
  if (!(table_error_min_arcsec >= 0.0) || !(table_error_max_arcsec >= table_error_min_arcsec)) {
    return invalidOption(why, "need 0 <= table_error_min_arcsec <= table_error_max_arcsec");
  }
  if (!(levelling_s > 0.0)) return invalidOption(why, "levelling_s must be > 0");
  if (!(output_interval_s > 0.0)) return invalidOption(why, "output_interval_s must be > 0");
  if (!direct.IsValid(why) || !indirect.IsValid(why)) return false;
  return true;
}

ValidationBench runValidationBench(const ValidationMotions& motions, std::uint64_t seed,
                                   const ValidationOptions& o) {
  ValidationBench b;
  b.seed = seed;
  std::string why;
  if (!o.IsValid(&why)) {
    b.status = Status::Error("invalid options: " + why);
    return b;
  }
  if (motions.direct.kind != TableKind::kTwoAxis ||
      motions.two_axis_runs.kind != TableKind::kTwoAxis ||
      motions.three_axis_runs.kind != TableKind::kThreeAxis ||
      motions.direct_three_axis.kind != TableKind::kThreeAxis ||
      motions.validation.kind != TableKind::kTwoAxis) {
    b.status = Status::Error(
        "motions: direct, 12-run and validation must be two-axis, the refinement three-axis");
    return b;
  }
  std::mt19937_64 rng(seed);
  const SensorModel sensors = randomSensors(rng, o);
  b.truth_two_axis.sensors = sensors;
  b.truth_two_axis.table = randomTable(rng, o, TableKind::kTwoAxis);
  b.truth_two_axis.table_kind = TableKind::kTwoAxis;
  b.truth_three_axis.sensors = sensors;
  b.truth_three_axis.table = randomTable(rng, o, TableKind::kThreeAxis);
  b.truth_three_axis.table_kind = TableKind::kThreeAxis;

  // Direct calibrations: (0) on the two-axis table, and the start of (3) on the three-axis one.
  Simulation direct2, direct3, sim;
  if (!simulateRun(b.truth_two_axis, motions.direct, o, true, seed * 8 + 1, &direct2, &why) ||
      !simulateRun(b.truth_three_axis, motions.direct_three_axis, o, true, seed * 8 + 2, &direct3,
                   &why)) {
    b.status = Status::Error("simulating a direct plan: " + why);
    return b;
  }
  // (0) direct calibration on the two-axis table; (2) and (3): the production pipeline on
  // each table (calib/indirect/bench_calibration.h: direct, refinement over the navigation
  // recording and the direct recording, second pass with the estimated nonorthogonality).
  struct Refine {
    const Motion* motion;
    const BenchTruth* truth;
    const Simulation* direct_sim;
    TableKind kind;
    int set;
    const char* name;
  };
  const Refine refines[2] = {
      {&motions.two_axis_runs, &b.truth_two_axis, &direct2, TableKind::kTwoAxis, 1, "12-run"},
      {&motions.three_axis_runs, &b.truth_three_axis, &direct3, TableKind::kThreeAxis, 2,
       "three-axis"}};
  BenchCalibrationOptions bo;
  bo.direct = o.direct;
  bo.indirect = o.indirect;
  for (const Refine& r : refines) {
    if (!simulateRun(*r.truth, *r.motion, o, true, seed * 8 + 3 + static_cast<std::uint64_t>(r.set),
                     &sim, &why)) {
      b.status = Status::Error(std::string("simulating the ") + r.name + " plan: " + why);
      return b;
    }
    BenchCalibrationInput in;
    in.direct.geometry.kind = r.kind;
    in.direct.site = o.site;
    in.direct.imu = r.direct_sim->imu;
    in.direct.table = r.direct_sim->table;
    in.direct.segments = r.direct_sim->segments;
    in.navigation.push_back({sim.imu, sim.table, sim.segments});
    const BenchCalibrationResult res = calibrateBench(in, bo);
    if (!res.status.HasResult()) {
      b.status = Status::Error(std::string(r.name) + ": " + res.status.message);
      return b;
    }
    if (r.set == 1) b.coefficients[0] = res.direct.report.values.sensors;
    b.coefficients[r.set] = res.refined.coefficients.values.sensors;
    b.base_tilt_estimate[r.set] = res.refined.coefficients.values.table.base_tilt;
  }
  b.base_tilt_estimate[0] = Vec2::Zero();

  // Validation: 8 headings on the two-axis table, each coefficient set.
  if (!simulateRun(b.truth_two_axis, motions.validation, o, o.validation_noise, seed * 8 + 7, &sim,
                   &why)) {
    b.status = Status::Error("simulating the validation plan: " + why);
    return b;
  }
  for (int i = 0; i < kSetCount; ++i) {
    if (!navigate(sim, b.coefficients[i], o, &b.curve[i], &why)) {
      b.status = Status::Error(std::string("validation with ") +
                               coefficientSetName(static_cast<CoefficientSet>(i)) + ": " + why);
      return b;
    }
  }
  // Eqs. 2-3: normalise by the direct solution's maxima.
  const NavErrorCurve& c0 = b.curve[0];
  const double nvE = std::max(maxAbs(c0.v_E), 1e-12), nvN = std::max(maxAbs(c0.v_N), 1e-12);
  const double nsE = std::max(maxAbs(c0.s_E), 1e-12), nsN = std::max(maxAbs(c0.s_N), 1e-12);
  for (int i = 0; i < kSetCount; ++i) {
    const NavErrorCurve& c = b.curve[i];
    b.max_v_E[i] = maxAbs(c.v_E) / nvE;
    b.max_v_N[i] = maxAbs(c.v_N) / nvN;
    b.max_s_E[i] = maxAbs(c.s_E) / nsE;
    b.max_s_N[i] = maxAbs(c.s_N) / nsN;
    double sum = 0.0;
    for (std::size_t k = 0; k < c.t.size(); ++k) {
      sum += std::hypot(c.s_E[k] / nsE, c.s_N[k] / nsN);
    }
    b.mean_S[i] = c.t.empty() ? 0.0 : sum / static_cast<double>(c.t.size());
  }
  for (int i = 0; i < kSetCount; ++i) b.ratio[i] = b.mean_S[i] / std::max(b.mean_S[0], 1e-300);
  b.status = Status::Ok();
  return b;
}

ValidationAggregate aggregate(const std::vector<ValidationBench>& benches) {
  ValidationAggregate a;
  std::vector<double> ratios[kSetCount];
  for (const ValidationBench& b : benches) {
    if (!b.status.ok) continue;
    ++a.benches;
    for (int i = 0; i < kSetCount; ++i) {
      a.mean_ratio[i] += b.ratio[i];
      a.worst_ratio[i] = std::max(a.worst_ratio[i], b.ratio[i]);
      if (b.ratio[i] <= kValidationTargetRatio) ++a.within_target[i];
      ratios[i].push_back(b.ratio[i]);
    }
  }
  if (a.benches == 0) return a;
  for (int i = 0; i < kSetCount; ++i) {
    a.mean_ratio[i] /= a.benches;
    std::vector<double>& r = ratios[i];
    std::sort(r.begin(), r.end());
    const std::size_t n = r.size();
    a.median_ratio[i] = n % 2 == 1 ? r[n / 2] : 0.5 * (r[n / 2 - 1] + r[n / 2]);
  }
  return a;
}

std::string positionErrorSvg(const ValidationBench& b) {
  constexpr double kW = 800, kH = 420, kL = 70, kR = 20, kT = 40, kB = 50;
  const NavErrorCurve& c0 = b.curve[0];
  const double nsE = std::max(maxAbs(c0.s_E), 1e-12), nsN = std::max(maxAbs(c0.s_N), 1e-12);
  double t_max = 1.0, y_max = 1e-12;
  std::vector<std::vector<double>> S(kSetCount);
  for (int i = 0; i < kSetCount; ++i) {
    const NavErrorCurve& c = b.curve[i];
    for (std::size_t k = 0; k < c.t.size(); ++k) {
      S[static_cast<std::size_t>(i)].push_back(std::hypot(c.s_E[k] / nsE, c.s_N[k] / nsN));
      y_max = std::max(y_max, S[static_cast<std::size_t>(i)].back());
      t_max = std::max(t_max, c.t[k] - c.t.front());
    }
  }
  std::string svg;
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" "
                "font-family=\"sans-serif\" font-size=\"12\">\n",
                kW, kH);
  svg += buf;
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  std::snprintf(buf, sizeof(buf),
                "<text x=\"%g\" y=\"22\">Validation bench seed %llu: total position error "
                "S = sqrt(dS_E^2 + dS_N^2) (normalised by direct maxima)</text>\n",
                kL, static_cast<unsigned long long>(b.seed));
  svg += buf;
  const double pw = kW - kL - kR, ph = kH - kT - kB;
  std::snprintf(buf, sizeof(buf),
                "<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"none\" "
                "stroke=\"black\"/>\n",
                kL, kT, pw, ph);
  svg += buf;
  for (int k = 0; k <= 4; ++k) {
    const double y = kT + ph - ph * k / 4.0;
    std::snprintf(buf, sizeof(buf), "<text x=\"%g\" y=\"%g\" text-anchor=\"end\">%.2f</text>\n",
                  kL - 5, y + 4, y_max * k / 4.0);
    svg += buf;
    const double x = kL + pw * k / 4.0;
    std::snprintf(buf, sizeof(buf),
                  "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">%.0f min</text>\n", x,
                  kT + ph + 18, t_max * k / 4.0 / 60.0);
    svg += buf;
  }
  const char* colors[kSetCount] = {"#d62728", "#1f77b4", "#2ca02c"};
  for (int i = 0; i < kSetCount; ++i) {
    const NavErrorCurve& c = b.curve[i];
    svg += "<polyline fill=\"none\" stroke-width=\"1.5\" stroke=\"";
    svg += colors[i];
    svg += "\" points=\"";
    for (std::size_t k = 0; k < c.t.size(); ++k) {
      std::snprintf(buf, sizeof(buf), "%.1f,%.1f ", kL + pw * (c.t[k] - c.t.front()) / t_max,
                    kT + ph - ph * S[static_cast<std::size_t>(i)][k] / y_max);
      svg += buf;
    }
    svg += "\"/>\n";
    std::snprintf(buf, sizeof(buf),
                  "<text x=\"%g\" y=\"%g\" fill=\"%s\">%s: mean S %.3f (ratio %.1f %%)</text>\n",
                  kL + 10, kT + 16 + 16.0 * i, colors[i],
                  coefficientSetName(static_cast<CoefficientSet>(i)), b.mean_S[i],
                  100.0 * b.ratio[i]);
    svg += buf;
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace imubench::calib
