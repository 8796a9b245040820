// The concealed-effect suite (issue 14 "Must show"): recordings of the bundled plans with
// extra physics switched on, analysed with no hint of what was added; one row per case.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "calib/explain/explain_fit.h"
#include "explain_sim.h"

namespace imubench::calib::testing {

struct ConcealedCase {
  std::string plan;   // plans/library/<plan>.toml
  std::string label;  // what is concealed, for the table
  EffectSet effects;  // the truth (empty: clean)
  std::uint64_t seed = 1;
};

struct CaseOutcome {
  std::string label, plan;
  bool ok = false;             // the analysis ran
  int concealed = 0;           // effects concealed
  int named = 0;               // of them accepted
  int false_positives = 0;     // accepted effects that were not concealed
  bool params_ok = true;       // every accepted concealed effect within 10 % or 2 sigma
  double worst_sigma = 0.0;    // largest |error| / sigma over the compared components
  double worst_percent = 0.0;  // largest |error| / |truth| of a physical parameter (vector), %
  bool rms_ok = true;          // post-fit RMS within 1.2x the noise floor, every channel
  std::string accepted;        // ids accepted
  int held = 0;                // parameters of named effects the analysis held (not fitted)
  std::vector<std::string> unseparable;  // ids reported unseparable (alone or in a pair)
  std::vector<std::string> unexcited;    // ids rejected as not excited
  int unexplained = 0;                   // windows left unexplained after the refit
  double seconds = 0.0;                  // wall time of simulation and analysis
};

inline bool contains(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// "Parameters within 10 % or 2 sigma", per physical parameter of the effect (a lever arm
// vector, a g-sensitivity matrix, a delay): its error vector within 10 % of the truth's
// magnitude, or within the 2-sigma region (chi^2 of the componentwise normalised errors below
// the 95.45 % quantile for its size; for one component exactly |error| <= 2 sigma).
// Components the analysis held (no sigma: the recording does not determine them) are not
// compared but counted (CaseOutcome::held): they are not a pass.
inline double chiSquareQuantile(double p, int k) {
  double lo = 0.0, hi = 10.0 * k + 100.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chiSquareSurvival(mid, k) > 1.0 - p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

inline void comparePhysicalParam(const ExplainAccepted& a, const std::vector<double>& truth,
                                 std::size_t off, std::size_t n, CaseOutcome* o) {
  double e2 = 0.0, t2 = 0.0, chi2 = 0.0;
  int compared = 0;
  for (std::size_t k = off; k < off + n && k < a.values.size() && k < truth.size(); ++k) {
    const double err = a.values[k] - truth[k];
    if (!(std::isfinite(a.sigmas[k]) && a.sigmas[k] > 0)) {
      if (truth[k] != 0.0) ++o->held;
      continue;
    }
    e2 += err * err;
    t2 += truth[k] * truth[k];
    chi2 += std::pow(err / a.sigmas[k], 2);
    o->worst_sigma = std::max(o->worst_sigma, std::abs(err) / a.sigmas[k]);
    ++compared;
  }
  if (compared == 0) return;
  const double pct = t2 > 0.0 ? 100.0 * std::sqrt(e2 / t2) : 0.0;
  o->worst_percent = std::max(o->worst_percent, pct);
  const bool within_sigma = chi2 <= chiSquareQuantile(0.9545, compared);
  if (!(within_sigma || (t2 > 0.0 && pct <= 10.0))) o->params_ok = false;
}

// The value of an environment switch ("" when unset). Only the main thread reads them, before
// any worker starts, and nothing in the tests calls setenv.
inline std::string envText(const char* name) {
  const char* v = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): see above
  return v != nullptr ? std::string(v) : std::string();
}

// Simulates the case along `motion` (the plan's, possibly with a temperature history) and
// analyses it with no hint of the concealed effects; `verbose` prints the analysis
// (EXPLAIN_VERBOSE, read by the caller).
inline CaseOutcome runCase(const ConcealedCase& c, const Motion& motion, bool verbose = false) {
  const auto start = std::chrono::steady_clock::now();
  CaseOutcome o;
  o.label = c.label;
  o.plan = c.plan;
  const SimulatedRecording rec = simulateWith(motion, c.effects, c.seed);
  const ExplainResult r = explainSimulated(rec);
  o.ok = r.status.ok;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (verbose) std::printf("%s", summary(r).c_str());
  if (!r.status.ok) return o;
  for (const ExplainUnseparable& u : r.unseparable) {
    for (const std::string& id : u.effects) o.unseparable.push_back(id);
  }
  for (const ExplainRejected& x : r.rejected) {
    if (std::isnan(x.delta_bic)) o.unexcited.push_back(x.effect);
  }
  o.unexplained = static_cast<int>(r.unexplained.size());
  const std::vector<EffectId> truth = c.effects.enabled();
  o.concealed = static_cast<int>(truth.size());
  for (const ExplainAccepted& a : r.accepted) {
    o.accepted += (o.accepted.empty() ? "" : ",") + a.effect;
    const std::optional<EffectId> id = effectFromName(a.effect);
    if (!id || !c.effects.has(*id)) {
      ++o.false_positives;
      continue;
    }
    ++o.named;
    const std::vector<double> t = c.effects.flat(*id);
    std::size_t off = 0;
    for (const ParamSpec& spec : paramSpecs(*id)) {
      const std::size_t n = static_cast<std::size_t>(paramSize(spec.shape));
      if (spec.kind != ParamKind::kReal) {
        // A discrete parameter (angle_harmonic's axis and order): the analysis' pick must be
        // the concealed one.
        if (off >= a.values.size() || a.values[off] != t[off]) o.params_ok = false;
      } else if (std::string(spec.name) != "t_ref_c") {
        comparePhysicalParam(a, t, off, n, &o);
      }
      off += n;
    }
  }
  for (int ch = 0; ch < 6; ++ch) {
    if (r.rms_after[ch] > 1.2 * r.noise_rms[ch]) o.rms_ok = false;
  }
  return o;
}

inline void printOutcome(const CaseOutcome& o, const std::string& verdict = "") {
  std::printf(
      "%-19s %-30s %-3s named %d/%d err %6.2f sig %7.2f %% held %d fp %d rms %-4s "
      "%5.1fs %-10s [%s]\n",
      o.plan.c_str(), o.label.c_str(), o.ok ? "ok" : "ERR", o.named, o.concealed, o.worst_sigma,
      o.worst_percent, o.held, o.false_positives, o.rms_ok ? "ok" : "HIGH", o.seconds,
      verdict.c_str(), o.accepted.c_str());
}

// Effect magnitudes of the issue, in SI.
inline EffectSet leverArm(const Vec3& r) {
  EffectSet e;
  e.enable(EffectId::kLeverArm);
  e.lever_arm->r_m = r;
  return e;
}
inline EffectSet timeDelay(double tau) {
  EffectSet e;
  e.enable(EffectId::kTimeDelay);
  e.time_delay->tau_s = tau;
  return e;
}
// g-sensitivity of deg/h per g on the diagonal and half of it off one diagonal entry.
inline EffectSet gSensitivity(double deg_h_per_g) {
  EffectSet e;
  e.enable(EffectId::kGyroGSensitivity);
  const double k = deg_h_per_g * kDegPerHourToRadPerSec / 9.80665;
  e.gyro_g_sensitivity->G = Mat3::Identity() * k;
  e.gyro_g_sensitivity->G(0, 2) = 0.5 * k;
  return e;
}
inline EffectSet scaleAsymmetry(double ppm) {
  EffectSet e;
  e.enable(EffectId::kScaleAsymmetry);
  e.scale_asymmetry->gyro = Vec3(1.0, -0.6, 0.8) * ppm * 1e-6;
  return e;
}
// K2 of ug/g^2 on every axis (u + k2 u^2 with u in m/s^2).
inline EffectSet accelK2(double ug_per_g2) {
  EffectSet e;
  e.enable(EffectId::kAccelK2);
  e.accel_k2->k2 = Vec3(1.0, -0.8, 0.6) * ug_per_g2 * 1e-6 / 9.80665;
  return e;
}
inline EffectSet thermalBias(double ug_per_c) {
  EffectSet e;
  e.enable(EffectId::kThermalBias);
  e.thermal_bias->k_accel = Vec3(1.0, -0.7, 0.5) * ug_per_c * 9.80665e-6;
  return e;
}
inline EffectSet merged(EffectSet a, const EffectSet& b) {
  for (EffectId id : b.enabled()) {
    std::string why;
    const std::vector<double> v = b.flat(id);
    a.setFlat(id, v, &why);
  }
  return a;
}

}  // namespace imubench::calib::testing
