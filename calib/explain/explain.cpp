#include "calib/explain/explain.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <limits>
#include <map>
#include <set>

#include "calib/explain/explain_fit.h"
#include "calib/explain/explain_revisit.h"
#include "calib/indirect/indirect_calibration.h"
#include "calib/recording_checks.h"

namespace imubench::calib {
namespace {

constexpr std::array<const char*, 6> kChannelNames = {"accel.x", "accel.y", "accel.z",
                                                      "gyro.x",  "gyro.y",  "gyro.z"};
// A regressor whose largest unwhitened value is below this (reading units per SI parameter
// unit) has no term in this recording: ~100x the central-difference rounding of readings of
// order 10 with a 1e-6 step.
constexpr double kNotExcited = 1e-7;

// Table error groups of the coefficient file (interchange.md), candidates when the baseline
// did not estimate them; ids the registry may also list.
constexpr std::array<const char*, 4> kTableGroups = {"base_tilt", "nonorthogonality", "mounting",
                                                     "encoder_zero"};
// Registry ids that are not deterministic terms with fittable flat parameters here:
// bias_instability is a noise process (reported from the Allan curve).
constexpr std::array<const char*, 1> kNotRegressed = {"bias_instability"};

// What motion separates or excites an effect (report text only).
std::string separatingMotion(const std::string& id) {
  static const std::map<std::string, std::string> hints = {
      {"lever_arm", "constant-rate runs about each axis at two or more rates"},
      {"size_effect", "rate runs about each of the three axes"},
      {"time_delay", "rotations in both directions at several rates and accelerations"},
      {"accel_delay", "runs about horizontal axes at several rates (changing specific force)"},
      {"gyro_g_sensitivity", "static holds with each axis up and down"},
      {"thermal_bias", "a temperature sweep"},
      {"thermal_scale", "a temperature sweep with rate runs or several positions per temperature"},
      {"scale_asymmetry", "rate runs in both directions about each axis"},
      {"accel_k2", "static positions with each accelerometer axis up, down and at 45 deg"},
      {"latitude_error", "static holds at several headings of the vertical axis"},
      {"gravity_error",
       "an independent gravity reference (it acts as a common accelerometer "
       "scale)"},
      {"base_tilt", "rotations about both table axes (navigation-based runs)"},
      {"nonorthogonality", "runs about the inner axis with the outer axis at several angles"},
      {"mounting", "rotations about both table axes with the device turned on the platform"},
      {"encoder_zero", "holds at several angles of each axis, both directions"},
      {"angle_harmonic", "holds at eight or more angles over a full turn of each axis"},
  };
  const auto it = hints.find(id);
  return it != hints.end() ? it->second
                           : "a motion that excites it differently from the baseline terms";
}

enum class GateStatus {
  kActive,
  kUnexcited,
  kBaselineCollinear,
  kPairUnseparable,
  kInconsistent  // accepted, but its parameters change along the recording (see below)
};

struct Candidate {
  std::string id;
  std::vector<std::string> names;  // flat names of its parameters
  std::vector<int> cols;           // their columns in the candidate matrix
  std::vector<int> active;         // columns that enter the fit
  GateStatus status = GateStatus::kActive;
  std::string held_note;     // parameters held and why
  std::string inconsistent;  // why it was withdrawn (kInconsistent)
  bool all_or_none = false;  // ExplainCandidateSpec::all_or_none
};

// Static holds of the recording as readings (rates), trimmed.
// The readings of every static hold, trimmed. The samples' times must increase (checked).
std::vector<HoldReadings> staticHolds(const ExplainInput& in, const ExplainOptions& o) {
  std::vector<HoldReadings> holds;
  for (const Segment& s : in.segments) {
    if (s.kind != SegmentKind::kStatic) continue;
    const double a = s.t0 + o.static_trim_s, b = s.t1 - o.static_trim_s;
    if (b - a < o.min_static_s) continue;
    HoldReadings h;
    double dt_sum = 0.0;
    // Samples in (a, b] after the first (whose interval is unknown).
    const auto first = std::partition_point(in.imu.begin() + 1, in.imu.end(),
                                            [a](const nav::ImuSample& x) { return x.t <= a; });
    for (auto x = first; x != in.imu.end() && x->t <= b; ++x) {
      const double dt = x->t - std::prev(x)->t;
      h.accel.push_back(x->dvel / dt);
      h.gyro.push_back(x->dtheta / dt);
      dt_sum += dt;
    }
    if (h.accel.size() < 8) continue;
    h.dt = dt_sum / static_cast<double>(h.accel.size());
    holds.push_back(std::move(h));
  }
  return holds;
}

bool wanted(const ExplainOptions& o, const std::string& id) {
  return o.candidates.empty() ||
         std::find(o.candidates.begin(), o.candidates.end(), id) != o.candidates.end();
}

// Candidate effects of a table recording: the table groups the baseline did not estimate,
// then every registry id.
std::vector<ExplainCandidateSpec> candidateEffects(const ExplainInput& in,
                                                   const ExplainOptions& o) {
  std::vector<ExplainCandidateSpec> out;
  BenchTruth t = in.baseline.values;
  t.table_kind = in.geometry.kind;
  std::map<std::string, ExplainCandidateSpec> table;
  for (const std::string& n : flatNames(t)) {
    if (n.rfind("table.", 0) != 0) continue;
    if (std::find(in.baseline_table_params.begin(), in.baseline_table_params.end(), n) !=
        in.baseline_table_params.end()) {
      continue;
    }
    const std::string group = n.substr(6, n.find('.', 6) - 6);
    table[group].id = group;
    table[group].names.push_back(n);
  }
  for (const char* g : kTableGroups) {
    if (table.count(g) && wanted(o, g)) out.push_back(table[g]);
  }
  for (const ExplainCandidateSpec& c : registryCandidates(o)) out.push_back(c);
  return out;
}

// Names of the (up to two) baseline coefficients whose columns a column resembles most.
std::string mimics(const Eigen::MatrixXd& Jb, const std::vector<std::string>& names,
                   const Eigen::VectorXd& c) {
  std::vector<std::pair<double, std::string>> cos;
  for (int j = 0; j < Jb.cols(); ++j) {
    const double d = Jb.col(j).norm() * c.norm();
    if (d > 0.0) cos.push_back({std::abs(Jb.col(j).dot(c)) / d, names[static_cast<size_t>(j)]});
  }
  std::sort(cos.rbegin(), cos.rend());
  std::string s;
  for (std::size_t k = 0; k < std::min<std::size_t>(2, cos.size()); ++k) {
    s += (k ? ", " : "") + cos[k].second;
  }
  return s.empty() ? "the baseline coefficients" : s;
}

struct GateInput {
  const Eigen::MatrixXd* Jb;
  const std::vector<std::string>* baseline_names;
  const Eigen::MatrixXd* C;      // whitened candidate columns
  const Eigen::MatrixXd* Cperp;  // the same off the baseline column space
  const std::vector<double>* raw_max;
};

// Per-parameter and within-effect part of the gate.
void gateParameters(const GateInput& g, const ExplainOptions& o, Candidate* c) {
  std::vector<int> rem;
  std::string collinear_with;
  for (std::size_t k = 0; k < c->cols.size(); ++k) {
    const int j = c->cols[k];
    const double n = g.C->col(j).norm();
    if ((*g.raw_max)[static_cast<size_t>(j)] < kNotExcited || n == 0.0) continue;
    if (g.Cperp->col(j).norm() < o.baseline_collinear * n) {
      c->held_note +=
          c->names[k] + " mimics " + mimics(*g.Jb, *g.baseline_names, g.C->col(j)) + "; ";
      collinear_with = mimics(*g.Jb, *g.baseline_names, g.C->col(j));
      continue;
    }
    rem.push_back(j);
  }
  // Combinations of the remaining parameters that the baseline (or the effect's other
  // parameters) absorb: drop the parameter dominating the weakest direction until none is.
  while (!rem.empty()) {
    Eigen::MatrixXd Z(g.Cperp->rows(), static_cast<int>(rem.size()));
    for (std::size_t k = 0; k < rem.size(); ++k) {
      Z.col(static_cast<int>(k)) = g.Cperp->col(rem[k]) / g.C->col(rem[k]).norm();
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(Z, Eigen::ComputeThinV);
    const int last = static_cast<int>(rem.size()) - 1;
    if (svd.singularValues()(last) >= o.baseline_collinear) break;
    Eigen::Index worst = 0;
    svd.matrixV().col(last).cwiseAbs().maxCoeff(&worst);
    const int j = rem[static_cast<std::size_t>(worst)];
    for (std::size_t k = 0; k < c->cols.size(); ++k) {
      if (c->cols[k] == j) c->held_note += c->names[k] + " in a combination the data absorb; ";
    }
    rem.erase(rem.begin() + worst);
  }
  c->active = rem;
  if (!rem.empty()) return;
  c->status = collinear_with.empty() && c->held_note.empty() ? GateStatus::kUnexcited
                                                             : GateStatus::kBaselineCollinear;
}

Eigen::MatrixXd columnsOf(const Eigen::MatrixXd& M, const std::vector<int>& cols) {
  Eigen::MatrixXd out(M.rows(), static_cast<int>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) out.col(static_cast<int>(k)) = M.col(cols[k]);
  return out;
}

// Flat name of candidate column j.
const std::string& nameOfColumn(const Candidate& c, int j) {
  for (std::size_t k = 0; k < c.cols.size(); ++k) {
    if (c.cols[k] == j) return c.names[k];
  }
  return c.id;
}

// Parameters of b to hold so that no combination of b's active columns lies within
// unseparable_cos of a's column space (the same test as gateParameters against the baseline:
// the weakest direction of b's columns, unit-normalised and projected off a, is dropped by
// its dominating parameter until none is that close). Returns the held flat names.
std::vector<std::string> holdSharedWith(const GateInput& g, const ExplainOptions& o,
                                        const Candidate& a, Candidate* b) {
  std::vector<std::string> held;
  const Eigen::MatrixXd A = columnBasis(columnsOf(*g.Cperp, a.active), 1e-9);
  if (A.cols() == 0) return held;
  const double sine = std::sqrt(std::max(0.0, 1.0 - o.unseparable_cos * o.unseparable_cos));
  while (!b->active.empty()) {
    Eigen::MatrixXd Z(g.Cperp->rows(), static_cast<int>(b->active.size()));
    for (std::size_t k = 0; k < b->active.size(); ++k) {
      const Eigen::VectorXd z = g.Cperp->col(b->active[k]);
      Z.col(static_cast<int>(k)) = z / std::max(z.norm(), 1e-300);
    }
    const Eigen::MatrixXd Zoff = Z - A * (A.transpose() * Z);
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(Zoff, Eigen::ComputeThinV);
    const int last = static_cast<int>(b->active.size()) - 1;
    if (svd.singularValues()(last) >= sine) break;
    Eigen::Index worst = 0;
    svd.matrixV().col(last).cwiseAbs().maxCoeff(&worst);
    held.push_back(nameOfColumn(*b, b->active[static_cast<std::size_t>(worst)]));
    b->active.erase(b->active.begin() + worst);
  }
  return held;
}

// Between-effect part of the gate: two candidates whose projected column spaces share a
// direction cannot be told apart along it. The earlier candidate (table groups first, in
// kTableGroups order, then the registry's order) keeps the shared direction, so the signal
// along it stays explained by one named effect instead of leaking into a wrong one; the later
// one holds the parameters spanning it at zero, and the pair is reported unseparable with the
// motion that would separate them. A candidate left with no parameter is not selected.
void gatePairs(const GateInput& g, const ExplainOptions& o, std::vector<Candidate>* cands,
               ExplainResult* res) {
  for (std::size_t a = 0; a < cands->size(); ++a) {
    for (std::size_t b = a + 1; b < cands->size(); ++b) {
      Candidate& ca = (*cands)[a];
      Candidate& cb = (*cands)[b];
      if (ca.status != GateStatus::kActive || cb.status != GateStatus::kActive) continue;
      const std::vector<std::string> held = holdSharedWith(g, o, ca, &cb);
      if (held.empty()) continue;
      std::string names;
      for (const std::string& n : held) names += (names.empty() ? "" : ", ") + n;
      const bool all = cb.active.empty();
      if (all) cb.status = GateStatus::kPairUnseparable;
      cb.held_note += names + " shares its effect on the readings with " + ca.id + "; ";
      res->unseparable.push_back(
          {{ca.id, cb.id},
           ca.id + " and " + cb.id + " change the readings the same way on this recording" +
               (all ? "" : " along " + names) +
               " (within the principal-angle cosine limit, after removing the baseline "
               "coefficients): that part is reported as " +
               ca.id + (all ? "; " + cb.id + " is not selected" : ", " + names + " held at zero") +
               ". To separate them record " + separatingMotion(ca.id) + " and " +
               separatingMotion(cb.id)});
    }
  }
}

// Nested least squares on the projected candidate columns (Gram form).
class Selector {
 public:
  Selector(const Eigen::MatrixXd& Cperp, const Eigen::VectorXd& rperp,
           const std::vector<Candidate>* cands)
      : cands_(cands), r2_(rperp.squaredNorm()) {
    G_ = Cperp.transpose() * Cperp;
    b_ = Cperp.transpose() * rperp;
  }
  double chi2(const std::vector<std::size_t>& set) const {
    std::vector<int> cols;
    for (std::size_t g : set) {
      for (int j : (*cands_)[g].active) cols.push_back(j);
    }
    if (cols.empty()) return r2_;
    const int m = static_cast<int>(cols.size());
    Eigen::MatrixXd G(m, m);
    Eigen::VectorXd b(m);
    for (int i = 0; i < m; ++i) {
      b(i) = b_(cols[static_cast<size_t>(i)]);
      for (int k = 0; k < m; ++k)
        G(i, k) = G_(cols[static_cast<size_t>(i)], cols[static_cast<size_t>(k)]);
    }
    const Eigen::VectorXd d = G.diagonal().cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd Gn = d.asDiagonal() * G * d.asDiagonal();
    const Eigen::VectorXd x = Gn.completeOrthogonalDecomposition().solve(d.cwiseProduct(b));
    return r2_ - d.cwiseProduct(b).dot(x);
  }
  int params(const std::vector<std::size_t>& set) const {
    int k = 0;
    for (std::size_t g : set) k += static_cast<int>((*cands_)[g].active.size());
    return k;
  }

 private:
  const std::vector<Candidate>* cands_;
  double r2_;
  Eigen::MatrixXd G_;
  Eigen::VectorXd b_;
};

struct Selection {
  std::vector<std::size_t> accepted;
  std::map<std::size_t, ExplainAccepted> stats;
};

// LR statistic and BIC difference of group g against the set without it.
ExplainAccepted testGroup(const Selector& sel, std::vector<std::size_t> with, std::size_t g,
                          double scale, double log_n) {
  std::vector<std::size_t> without;
  for (std::size_t x : with) {
    if (x != g) without.push_back(x);
  }
  if (std::find(with.begin(), with.end(), g) == with.end()) with.push_back(g);
  const int k = sel.params(with) - sel.params(without);
  ExplainAccepted a;
  a.lr_stat = std::max(0.0, (sel.chi2(without) - sel.chi2(with)) / scale);
  a.delta_bic = a.lr_stat - k * log_n;
  a.p_value = chiSquareSurvival(a.lr_stat, k);
  return a;
}

Selection selectEffects(const Selector& sel, const std::vector<Candidate>& cands, double scale,
                        double log_n) {
  Selection s;
  for (std::size_t round = 0; round < 2 * cands.size() + 2; ++round) {
    // Forward: the candidate with the largest BIC gain, if positive.
    std::size_t best = cands.size();
    double best_bic = 0.0;
    for (std::size_t g = 0; g < cands.size(); ++g) {
      if (cands[g].status != GateStatus::kActive) continue;
      if (std::find(s.accepted.begin(), s.accepted.end(), g) != s.accepted.end()) continue;
      const double d = testGroup(sel, s.accepted, g, scale, log_n).delta_bic;
      if (d > best_bic) {
        best_bic = d;
        best = g;
      }
    }
    bool changed = false;
    if (best < cands.size()) {
      s.accepted.push_back(best);
      changed = true;
    }
    // Backward: drop the accepted effect whose removal the BIC favours most.
    std::size_t worst = cands.size();
    double worst_bic = 0.0;
    for (std::size_t g : s.accepted) {
      const double d = testGroup(sel, s.accepted, g, scale, log_n).delta_bic;
      if (d < worst_bic) {
        worst_bic = d;
        worst = g;
      }
    }
    if (worst < cands.size() && worst != best) {
      s.accepted.erase(std::find(s.accepted.begin(), s.accepted.end(), worst));
      changed = true;
    }
    if (!changed) break;
  }
  for (std::size_t g : s.accepted) s.stats[g] = testGroup(sel, s.accepted, g, scale, log_n);
  return s;
}

// Windows of bins (one segment, at most window_s long) whose mean residual exceeds the
// threshold in noise-floor sigmas; adjacent ones on the same channel and sign are merged.
// A window's sigma: the noise floor's deviation of a mean over its duration and the bins'
// interpolation uncertainty (model_sigma, per row), which does not average down.
std::vector<ExplainWindow> locateWindows(const std::vector<ExplainBin>& bins,
                                         const std::vector<double>& r,
                                         const std::vector<double>& model_sigma,
                                         const NoiseFloor& nf, const ExplainOptions& o,
                                         std::span<const Segment> segments) {
  std::vector<ExplainWindow> out;
  std::array<long, 6> open{-1, -1, -1, -1, -1, -1};  // index in out of the window being merged
  std::size_t b = 0;
  while (b < bins.size()) {
    std::size_t e = b;
    double T = 0.0;
    std::array<double, 6> sum{}, model{};
    while (e < bins.size() && bins[e].segment == bins[b].segment && (T < o.window_s || e == b)) {
      const double dt = bins[e].duration();
      T += dt;
      for (int c = 0; c < 6; ++c) {
        sum[c] += r[e * 6 + c] * dt;
        model[c] += model_sigma[e * 6 + c] * dt;
      }
      ++e;
    }
    for (int c = 0; c < 6; ++c) {
      const double mean = sum[c] / T;
      const double z = mean / std::hypot(nf.sigmaOfMean(c, T), model[c] / T);
      long& w = open[static_cast<std::size_t>(c)];
      if (std::abs(z) < o.unexplained_sigma) {
        w = -1;
        continue;
      }
      if (w >= 0 && (out[w].sigma > 0) == (z > 0)) {
        out[w].t1 = bins[e - 1].t1;
        if (std::abs(z) > std::abs(out[w].sigma)) out[w].sigma = z;
        continue;
      }
      const int seg = bins[b].segment;
      const std::string where =
          seg >= 0 ? std::string(segmentKindName(segments[static_cast<std::size_t>(seg)].kind)) +
                         " segment '" + segments[static_cast<std::size_t>(seg)].label + "'"
                   : std::string("a span outside the segments");
      out.push_back({bins[b].t0, bins[e - 1].t1, c, z, mean, "mean residual in " + where});
      w = static_cast<long>(out.size()) - 1;
    }
    b = e;
  }
  return out;
}

// Per-row sigmas: the noise floor's deviation of a mean over each bin's duration, and the
// encoder interpolation's uncertainty (model, when given, receives it alone): an angle error e
// at the bin's ends changes the mean rate by e / T, an attitude error e inside it the specific
// force by up to g e.
std::vector<double> rowSigmas(const ExplainData& d, const NoiseFloor& nf,
                              std::vector<double>* model = nullptr) {
  std::vector<double> s(d.bins.size() * 6);
  if (model) model->assign(s.size(), 0.0);
  const double g = nav::siteGravity(d.site);
  for (std::size_t b = 0; b < d.bins.size(); ++b) {
    const ExplainBin& bin = d.bins[b];
    const double rate_err = bin.angle_err_ends / bin.duration();
    const double force_err = g * bin.angle_err_inside;
    for (int c = 0; c < 6; ++c) {
      s[b * 6 + c] = std::hypot(nf.sigmaOfMean(c, bin.duration()), c < 3 ? force_err : rate_err);
      if (model) (*model)[b * 6 + c] = c < 3 ? force_err : rate_err;
    }
  }
  return s;
}

std::array<double, 6> channelRms(const std::vector<double>& r) {
  std::array<double, 6> out{};
  const std::size_t bins = r.size() / 6;
  for (std::size_t b = 0; b < bins; ++b) {
    for (int c = 0; c < 6; ++c) out[c] += r[b * 6 + c] * r[b * 6 + c];
  }
  for (double& v : out) v = bins ? std::sqrt(v / static_cast<double>(bins)) : 0.0;
  return out;
}

// Refusals before any work: bad samples, no table.
std::string checkInput(const ExplainInput& in, const ExplainOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) return "options: " + why;
  // Gaps between segments (a daemon restart during a run) are allowed, as for calibration.
  const RecordingCheck c = checkIncrements(in.imu, o.checks, "recording", in.segments);
  if (!c.ok) return c.message;
  if (in.table.size() < 2) return "the recording has no table angles (imu.csv needs table.csv)";
  return "";
}

// No static hold for the noise floor: nothing can be judged.
std::string checkHolds(const ExplainOptions& o, const std::vector<HoldReadings>& holds) {
  if (holds.empty()) {
    return "the recording has no static hold of at least " +
           std::to_string(o.min_static_s + 2 * o.static_trim_s) +
           " s: the noise floor cannot be measured, so no residual can be judged";
  }
  return "";
}

std::vector<std::string> baselineNamesOf(const ExplainInput& in) {
  std::vector<std::string> names;
  BenchTruth t = in.baseline.values;
  t.table_kind = in.geometry.kind;
  for (const std::string& n : flatNames(t)) {
    if (n.rfind("accel.", 0) == 0 || n.rfind("gyro.", 0) == 0) names.push_back(n);
  }
  for (const std::string& n : in.baseline_table_params) names.push_back(n);
  return names;
}

// The gate's verdicts that are not selections: not excited, collinear with the baseline.
void reportGate(const std::vector<Candidate>& cands, ExplainResult* res) {
  for (const Candidate& c : cands) {
    if (c.status == GateStatus::kUnexcited) {
      res->rejected.push_back({c.id,
                               "not excited by this recording (no term in any reading); it "
                               "would need " +
                                   separatingMotion(c.id),
                               std::numeric_limits<double>::quiet_NaN()});
    } else if (c.status == GateStatus::kBaselineCollinear) {
      res->unseparable.push_back(
          {{c.id},
           c.id + " is unseparable from the baseline coefficients on this recording (" +
               c.held_note + "): to separate it record " + separatingMotion(c.id)});
    } else if (c.status == GateStatus::kInconsistent) {
      res->rejected.push_back({c.id, "withdrawn: " + c.inconsistent, 0.0});
    } else if (c.status == GateStatus::kActive && !c.held_note.empty()) {
      res->notes.push_back(c.id + ": held at zero: " + c.held_note);
    }
  }
}

// The accepted effects' values and sigmas from the refit; the rejected ones with statistics.
void reportSelection(const std::vector<ExplainCandidateSpec>& specs,
                     const std::vector<Candidate>& cands, const Selection& sel,
                     const Selector& selector, double scale, double log_n,
                     const std::vector<std::string>& names, const RefitResult& fit,
                     ExplainResult* res) {
  for (std::size_t g = 0; g < cands.size(); ++g) {
    const Candidate& c = cands[g];
    if (c.status != GateStatus::kActive) continue;
    const auto it = sel.stats.find(g);
    if (it == sel.stats.end()) {
      const ExplainAccepted t = testGroup(selector, sel.accepted, g, scale, log_n);
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    "not warranted: BIC favours the model without it (LR %.1f on %d "
                    "parameters, p = %.3g)",
                    t.lr_stat, static_cast<int>(c.active.size()), t.p_value);
      res->rejected.push_back({c.id, buf, t.delta_bic});
      continue;
    }
    ExplainAccepted a = it->second;
    a.effect = c.id;
    // The held discrete parameters (no sigma), then the fitted ones: the registry's order.
    for (const auto& [name, value] : specs[g].fixed) {
      a.flat_names.push_back(name);
      a.values.push_back(value);
      a.sigmas.push_back(std::numeric_limits<double>::quiet_NaN());
    }
    for (std::size_t k = 0; k < c.names.size(); ++k) {
      const auto pos = std::find(names.begin(), names.end(), c.names[k]);
      a.flat_names.push_back(c.names[k]);
      a.values.push_back(stateValue(fit.state, c.names[k]));
      a.sigmas.push_back(pos == names.end()
                             ? std::numeric_limits<double>::quiet_NaN()
                             : fit.sigma[static_cast<std::size_t>(pos - names.begin())]);
    }
    res->accepted.push_back(std::move(a));
  }
}

void fillBins(const std::vector<ExplainBin>& bins, const std::vector<double>& before,
              const std::vector<double>& after, const std::vector<double>& sigma,
              ExplainResult* res) {
  res->bins.resize(bins.size());
  for (std::size_t b = 0; b < bins.size(); ++b) {
    ExplainBinResidual& x = res->bins[b];
    x.t0 = bins[b].t0;
    x.t1 = bins[b].t1;
    x.segment = bins[b].segment;
    x.moving = bins[b].moving;
    for (int c = 0; c < 6; ++c) {
      x.before[c] = before[b * 6 + c];
      x.after[c] = after[b * 6 + c];
      x.sigma[c] = sigma[b * 6 + c];
    }
  }
}

// The given-file tolerance of baseline coefficient n (ExplainOptions::given_max_*).
double givenTolerance(const std::string& n, const ExplainOptions& o) {
  if (n.find(".scale.") != std::string::npos) return o.given_max_scale;
  if (n.rfind("accel.bias.", 0) == 0) return o.given_max_accel_bias;
  if (n.rfind("gyro.bias.", 0) == 0) return o.given_max_gyro_bias;
  return o.given_max_misalignment;
}

// Given coefficients that the recording moves beyond the physical tolerances are not this
// IMU's: the first such coefficient, or "".
std::string givenMismatch(const ExplainProblem& p, const ExplainOptions& o, const BenchTruth& fit) {
  if (p.baseline_method != "given") return "";
  const BenchTruth& given = p.start.model;
  for (const std::string& n : p.baseline_names) {
    if (n.rfind("nuisance.", 0) == 0) continue;
    const double tol = givenTolerance(n, o);
    const double d = stateValue({fit, {}}, n) - stateValue({given, {}}, n);
    if (std::abs(d) > tol) {
      char buf[240];
      std::snprintf(buf, sizeof(buf),
                    "the given coefficients do not describe this IMU: the recording puts %s at "
                    "%.6g, %.3g away from the given %.6g (more than %.3g): coefficients of "
                    "another unit or range setting?",
                    n.c_str(), stateValue({fit, {}}, n), d, stateValue({given, {}}, n), tol);
      return buf;
    }
  }
  return "";
}

// A given baseline's coefficients this recording cannot determine to within their given-file
// tolerance: the sigma at the given values (whitened regressors, columns normalised, singular
// directions below 1e-7 of the largest unseen) above the tolerance. They are held at the given
// values: refitted, they would wander along directions the data barely see (a level recording:
// the horizontal accelerometers' scale, bias and misalignment trade against each other) and the
// given-file check would call the file another IMU's.
std::vector<std::string> undeterminedGiven(const ExplainProblem& p, const ExplainOptions& o,
                                           ExplainEvaluator* eval) {
  constexpr double kUnseen = 1e-7;
  Eigen::MatrixXd J = eval->jacobian(p.start, p.baseline_names);
  const int n = static_cast<int>(J.cols());
  Eigen::VectorXd d(n);
  for (int j = 0; j < n; ++j) {
    d(j) = J.col(j).norm();
    if (d(j) > 0.0) J.col(j) /= d(j);
  }
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const Eigen::MatrixXd& V = svd.matrixV();
  std::vector<std::string> held;
  for (int j = 0; j < n; ++j) {
    const std::string& name = p.baseline_names[static_cast<std::size_t>(j)];
    if (name.rfind("nuisance.", 0) == 0) continue;
    double var = 0.0;
    for (int k = 0; k < s.size(); ++k) {
      const bool unseen = s(k) <= kUnseen * s(0);
      if (unseen && std::abs(V(j, k)) > 1e-3) var = std::numeric_limits<double>::infinity();
      if (!unseen) var += V(j, k) * V(j, k) / (s(k) * s(k));
    }
    const double sigma =
        d(j) > 0.0 ? std::sqrt(var) / d(j) : std::numeric_limits<double>::infinity();
    if (!(sigma <= givenTolerance(name, o))) held.push_back(name);
  }
  return held;
}

}  // namespace

double explainChannelLimit(double bins, double fitted) {
  const double n = std::max(1.0, bins - fitted);
  // Wilson-Hilferty: chi^2_n quantile ~ n (1 - 2/(9n) + z sqrt(2/(9n)))^3, z(99.9 %) = 3.09.
  const double a = 2.0 / (9.0 * n);
  const double q = std::pow(1.0 - a + 3.09 * std::sqrt(a), 3);
  return std::max(1.2, std::sqrt(q));
}

std::vector<int> channelsAboveFloor(const ExplainResult& r) {
  std::vector<int> out;
  for (int c = 0; c < 6; ++c) {
    const std::size_t k = static_cast<std::size_t>(c);
    if (r.channel_normalised_rms[k] > r.channel_limit[k]) out.push_back(c);
  }
  return out;
}

std::string explainVerdict(const ExplainResult& r) {
  if (r.noise.anyResolutionLimited()) {
    std::string chans;
    for (int c = 0; c < 6; ++c) {
      if (r.noise.resolution_limited[static_cast<std::size_t>(c)]) {
        chans += std::string(chans.empty() ? "" : ", ") + explainChannelName(c);
      }
    }
    return "not judged: the static readings of " + chans +
           " show no noise (noise-free or quantisation-limited data: at most " +
           std::to_string(kMaxResolutionValues) +
           " distinct values per hold), so there is no noise floor to judge the residual "
           "against; figures in noise-floor units are not meaningful";
  }
  const std::vector<int> above = channelsAboveFloor(r);
  std::string chans;
  for (int c : above) {
    char buf[80];
    std::snprintf(buf, sizeof(buf), "%s%s %.2fx (limit %.2fx)", chans.empty() ? "" : ", ",
                  explainChannelName(c), r.channel_normalised_rms[static_cast<std::size_t>(c)],
                  r.channel_limit[static_cast<std::size_t>(c)]);
    chans += buf;
  }
  if (!r.unexplained.empty()) {
    return std::to_string(r.unexplained.size()) +
           " window(s) beyond the noise floor that nothing in the library accounts for" +
           (above.empty() ? std::string() : "; channels above the noise floor: " + chans);
  }
  if (!above.empty()) {
    return "none stands out as a window, but the residual after the refit is above the noise floor "
           "on " +
           chans + ": structure spread over the recording that no library effect explains";
  }
  return "none: after the refit the residual of every channel is within the noise floor";
}

const char* explainChannelName(int channel) {
  return kChannelNames[static_cast<std::size_t>(std::clamp(channel, 0, 5))];
}

bool ExplainOptions::IsValid(std::string* why) const {
  if (!model.IsValid(why) || !checks.IsValid(why)) return false;
  if (!(static_trim_s >= 0.0 && min_static_s > 0.0 && window_s > 0.0)) {
    *why = "static_trim_s >= 0, min_static_s > 0 and window_s > 0 required";
    return false;
  }
  if (!(baseline_collinear > 0.0 && baseline_collinear < 1.0 && unseparable_cos > 0.0 &&
        unseparable_cos < 1.0 && unexplained_sigma > 0.0 && fd_step > 0.0 && threads >= 1 &&
        passes >= 1 && consistency_parts >= 1 && consistency_p > 0.0 && consistency_p < 1.0 &&
        correlation_window_s >= 0.0 && correlation_sigmas >= 0.0)) {
    *why =
        "baseline_collinear and unseparable_cos in (0, 1), unexplained_sigma, fd_step > 0, "
        "threads >= 1, passes >= 1, consistency_parts >= 1, consistency_p in (0, 1), "
        "correlation_window_s >= 0, correlation_sigmas >= 0 required";
    return false;
  }
  if (!(harmonic_max_order >= 1 && harmonic_min_turn_rad > 0.0)) {
    *why = "harmonic_max_order >= 1 and harmonic_min_turn_rad > 0 required";
    return false;
  }
  if (!refit.IsValid(why)) return false;
  for (const std::string& c : candidates) {
    const bool table = std::find(kTableGroups.begin(), kTableGroups.end(), c) != kTableGroups.end();
    if (!table && !effectFromName(c)) {
      *why = "unknown effect id '" + c + "'";
      return false;
    }
  }
  return true;
}

namespace {

// The state with a candidate's discrete parameters set (the effect enabled at them).
ExplainState withFixed(const ExplainState& at, const ExplainCandidateSpec::Fixed& fixed) {
  ExplainState s = at;
  for (const auto& [name, value] : fixed) {
    std::string why;
    setStateValue(&s, name, value, &why);
  }
  return s;
}

// The linearised problem at the baseline: whitened residual and columns, the baseline's
// column space, candidates' columns projected off it.
struct Linearised {
  Eigen::VectorXd r0, rperp;
  Eigen::MatrixXd Jb, Ub, C, Cperp;
  std::vector<double> raw_max;
  std::vector<std::string> cnames;
  std::vector<Candidate> cands;
  int dof_b = 0;
};

Linearised linearise(const ExplainProblem& p, ExplainEvaluator* eval, const ExplainState& at) {
  Linearised L;
  L.r0 = eval->residual(at);
  L.Jb = eval->jacobian(at, p.baseline_names);
  L.Ub = columnBasis(L.Jb, 1e-7);
  std::vector<std::string> plain;  // columns of the candidates without discrete parameters
  for (const ExplainCandidateSpec& spec : p.candidates) {
    Candidate c;
    c.id = spec.id;
    c.names = spec.names;
    c.all_or_none = spec.all_or_none;
    for (const std::string& nm : c.names) {
      c.cols.push_back(static_cast<int>(L.cnames.size()));
      L.cnames.push_back(nm);
      if (spec.fixed.empty()) plain.push_back(nm);
    }
    L.cands.push_back(std::move(c));
  }
  // The plain candidates' columns at `at`, each other candidate's at `at` with its discrete
  // parameters set.
  std::vector<double> raw_plain;
  const Eigen::MatrixXd P = eval->jacobian(at, plain, &raw_plain);
  L.C.resize(eval->rows(), static_cast<int>(L.cnames.size()));
  L.raw_max.assign(L.cnames.size(), 0.0);
  int next_plain = 0;
  for (std::size_t g = 0; g < p.candidates.size(); ++g) {
    const ExplainCandidateSpec& spec = p.candidates[g];
    const std::vector<int>& cols = L.cands[g].cols;
    if (spec.fixed.empty()) {
      for (int j : cols) {
        L.C.col(j) = P.col(next_plain);
        L.raw_max[static_cast<std::size_t>(j)] = raw_plain[static_cast<std::size_t>(next_plain)];
        ++next_plain;
      }
      continue;
    }
    if (!spec.variants.empty()) continue;  // chooseVariants computes the chosen variant's
    std::vector<double> raw;
    const Eigen::MatrixXd S = eval->jacobian(withFixed(at, spec.fixed), spec.names, &raw);
    for (std::size_t k = 0; k < cols.size(); ++k) {
      L.C.col(cols[k]) = S.col(static_cast<int>(k));
      L.raw_max[static_cast<std::size_t>(cols[k])] = raw[k];
    }
  }
  L.Cperp = projectOff(L.Ub, L.C);
  L.rperp = projectOff(L.Ub, L.r0);
  L.dof_b = eval->rows() - static_cast<int>(L.Ub.cols());
  return L;
}

// Residual of the least-squares fit of r on the columns of A (normalised columns, rank-revealing
// solve: columns the others already span add nothing), and the rank it found.
Eigen::VectorXd fitResidual(const Eigen::MatrixXd& A, const Eigen::VectorXd& r, int* rank) {
  *rank = 0;
  if (A.cols() == 0) return r;
  Eigen::VectorXd d(A.cols());
  for (int j = 0; j < A.cols(); ++j) {
    const double n = A.col(j).norm();
    d(j) = n > 0.0 ? 1.0 / n : 0.0;
  }
  const Eigen::MatrixXd An = A * d.asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(An);
  cod.setThreshold(1e-9);
  *rank = static_cast<int>(cod.rank());
  return r - An * cod.solve(r);
}

Eigen::VectorXd fitResidual(const Eigen::MatrixXd& A, const Eigen::VectorXd& r) {
  int rank = 0;
  return fitResidual(A, r, &rank);
}

// Chi^2 of that fit.
double fitChi2(const Eigen::MatrixXd& A, const Eigen::VectorXd& r, int* rank) {
  return fitResidual(A, r, rank).squaredNorm();
}

// Effective-n correction of the test scale. The likelihood-ratio statistics assume
// independent bins; a residual the library does not model (a slow bias wander, a drift) is
// correlated from bin to bin, and then the number of independent bins is smaller than the bin
// count by the long-run variance factor 1 + 2 sum_k w_k rho_k (Bartlett weights w_k over lags
// up to correlation_window_s; rho_k the residual's autocorrelation at lag k, pooled over the
// channels by their variance). Every statistic's variance grows by that factor, so the scale
// does too. Under white residual the estimate scatters about 1 with a standard error se; only
// its excess over correlation_sigmas se is applied, so white residual keeps scale 1.
double correlationFactor(const Eigen::VectorXd& e, const std::vector<ExplainBin>& bins,
                         const ExplainOptions& o) {
  const std::size_t n = bins.size();
  if (n < 8 || o.correlation_window_s <= 0.0) return 1.0;
  double var = 0.0, cov = 0.0, w2 = 0.0;
  for (std::size_t b = 0; b < n; ++b) {
    for (int c = 0; c < 6; ++c)
      var += e(static_cast<int>(b * 6) + c) * e(static_cast<int>(b * 6) + c);
  }
  if (!(var > 0.0)) return 1.0;
  const double bin_s = (bins.back().t1 - bins.front().t0) / static_cast<double>(n);
  const int lags =
      std::clamp(static_cast<int>(o.correlation_window_s / bin_s), 1, static_cast<int>(n / 4));
  for (int k = 1; k <= lags; ++k) {
    const double w = 1.0 - static_cast<double>(k) / (lags + 1);
    w2 += w * w;
    double g = 0.0;
    for (std::size_t b = 0; b + static_cast<std::size_t>(k) < n; ++b) {
      const std::size_t b2 = b + static_cast<std::size_t>(k);
      if (bins[b2].t0 - bins[b].t1 > o.correlation_window_s) continue;
      for (int c = 0; c < 6; ++c) {
        g += e(static_cast<int>(b * 6) + c) * e(static_cast<int>(b2 * 6) + c);
      }
    }
    cov += w * g;
  }
  const double f = 1.0 + 2.0 * cov / var;
  // White residual: each lag's pooled autocorrelation has variance ~1/(6n).
  const double se = 2.0 * std::sqrt(w2 / (6.0 * static_cast<double>(n)));
  return std::max(1.0, f - o.correlation_sigmas * se);
}

// Constancy test of the accepted effects (a Chow test): a physical effect has the same
// parameters all along the recording, so letting an accepted effect's parameters take other
// values in each of consistency_parts consecutive parts of it (by time) must not improve the
// fit beyond noise. Residual structure outside the library (a bias step, a drift, a
// sinusoid) that an effect merely correlates with does improve it: that effect is withdrawn.
// Returns the accepted effect with the most significant change (and its reason), or npos.
std::size_t leastConstant(const Linearised& L, const std::vector<ExplainBin>& bins,
                          const std::vector<std::size_t>& accepted, double scale,
                          const ExplainOptions& o, std::string* why) {
  const int parts = o.consistency_parts;
  if (accepted.empty() || parts < 2 || bins.empty()) return std::string::npos;
  // Part of each row: consecutive spans of equal duration.
  const double t0 = bins.front().t0, span = bins.back().t1 - t0;
  std::vector<int> part(bins.size());
  for (std::size_t b = 0; b < bins.size(); ++b) {
    const double mid = 0.5 * (bins[b].t0 + bins[b].t1);
    part[b] = std::clamp(static_cast<int>((mid - t0) / span * parts), 0, parts - 1);
  }
  std::vector<int> cols;
  for (std::size_t g : accepted) {
    for (int j : L.cands[g].active) cols.push_back(j);
  }
  const Eigen::MatrixXd A = columnsOf(L.Cperp, cols);
  int rank = 0;
  const double chi2 = fitChi2(A, L.rperp, &rank);
  std::size_t worst = std::string::npos;
  double worst_p = o.consistency_p;
  for (std::size_t g : accepted) {
    const std::vector<int>& act = L.cands[g].active;
    // The effect's columns restricted to parts 1.. (part 0 keeps the common value), projected
    // off the baseline coefficients like every candidate column.
    Eigen::MatrixXd S(A.rows(), static_cast<int>(act.size()) * (parts - 1));
    for (int q = 1; q < parts; ++q) {
      for (std::size_t k = 0; k < act.size(); ++k) {
        Eigen::VectorXd c = L.C.col(act[k]);
        for (std::size_t b = 0; b < bins.size(); ++b) {
          if (part[b] != q) c.segment(static_cast<Eigen::Index>(b) * 6, 6).setZero();
        }
        S.col((q - 1) * static_cast<int>(act.size()) + static_cast<int>(k)) = c;
      }
    }
    Eigen::MatrixXd AS(A.rows(), A.cols() + S.cols());
    AS << A, projectOff(L.Ub, S);
    int rank_s = 0;
    const double chi2_s = fitChi2(AS, L.rperp, &rank_s);
    const int k = rank_s - rank;
    if (k <= 0) continue;
    const double lr = std::max(0.0, (chi2 - chi2_s) / scale);
    const double p = chiSquareSurvival(lr, k);
    if (p >= worst_p) continue;
    worst_p = p;
    worst = g;
    char buf[240];
    std::snprintf(buf, sizeof(buf),
                  "its parameters would have to change along the recording (fitted separately "
                  "over %d parts: LR %.1f on %d parameters, p = %.2g): the residual it fits is "
                  "not a constant effect",
                  parts, lr, k, p);
    *why = buf;
  }
  return worst;
}

// Per channel: the normalised RMS after the refit and its chance limit (the fit's parameters
// shared evenly among the channels' degrees of freedom).
void channelNormalised(const std::vector<double>& after, const std::vector<double>& sigma, int rank,
                       ExplainResult* res) {
  const std::size_t bins = after.size() / 6;
  for (int c = 0; c < 6; ++c) {
    double chi2 = 0.0;
    for (std::size_t b = 0; b < bins; ++b) {
      chi2 += std::pow(
          after[b * 6 + static_cast<std::size_t>(c)] / sigma[b * 6 + static_cast<std::size_t>(c)],
          2);
    }
    const double fitted = static_cast<double>(rank) / 6.0;
    const double dof = std::max(1.0, static_cast<double>(bins) - fitted);
    res->channel_normalised_rms[static_cast<std::size_t>(c)] = std::sqrt(chi2 / dof);
    res->channel_limit[static_cast<std::size_t>(c)] =
        explainChannelLimit(static_cast<double>(bins), fitted);
  }
}

// Residuals before and after, RMS, located windows, coefficients, bins.
void finish(const ExplainProblem& p, const ExplainOptions& o, const Linearised& L,
            ExplainEvaluator* eval, const RefitResult& fit, const std::vector<std::string>& names,
            ExplainResult* res) {
  const std::size_t n = static_cast<std::size_t>(eval->rows());
  std::vector<double> before(n);
  for (std::size_t i = 0; i < n; ++i) before[i] = L.rperp(static_cast<int>(i)) * eval->sigma()[i];
  const std::vector<double> after = eval->rawResidual(fit.state);
  double chi2_after = 0.0;
  for (std::size_t i = 0; i < n; ++i) chi2_after += std::pow(after[i] / eval->sigma()[i], 2);
  res->after_normalised_rms = std::sqrt(chi2_after / std::max(1, eval->rows() - fit.rank));
  channelNormalised(after, eval->sigma(), fit.rank, res);
  res->rms_before = channelRms(before);
  res->rms_after = channelRms(after);
  res->noise_rms = channelRms(eval->sigma());
  res->located = locateWindows(*p.bins, before, p.model_sigma, p.noise, o, p.segments);
  res->unexplained = locateWindows(*p.bins, after, p.model_sigma, p.noise, o, p.segments);
  for (ExplainWindow& w : res->unexplained) w.reason += ": no effect of the library explains it";
  nameRevisits(*p.bins, after, p.model_sigma, p.noise, o.unexplained_sigma, RevisitOptions{},
               &res->unexplained);
  res->coefficients.values = fit.state.model;
  for (std::size_t j = 0; j < names.size(); ++j) {
    if (names[j].rfind("nuisance.", 0) == 0) continue;
    if (std::isfinite(fit.sigma[j])) {
      res->coefficients.setSigma(names[j], fit.sigma[j]);
    } else {
      res->coefficients.setUnobservable(names[j]);
    }
  }
  fillBins(*p.bins, before, after, eval->sigma(), res);
}

}  // namespace

std::vector<ExplainCandidateSpec> registryCandidates(const ExplainOptions& o) {
  std::vector<ExplainCandidateSpec> out;
  for (EffectId id : kAllEffects) {
    const std::string name = effectName(id);
    if (std::find(kTableGroups.begin(), kTableGroups.end(), name) != kTableGroups.end()) continue;
    if (std::find(kNotRegressed.begin(), kNotRegressed.end(), name) != kNotRegressed.end()) {
      continue;
    }
    if (!wanted(o, name)) continue;
    ExplainCandidateSpec c;
    c.id = name;
    // Discrete parameters (a table axis, an order) are held at their defaults here;
    // explainRecording lists angle_harmonic's variants (addHarmonicVariants).
    EffectSet defaults;
    defaults.enable(id);
    const std::vector<double> value = defaults.flat(id);
    const std::vector<std::string> flat = flatParamNames(id);
    std::size_t k = 0;
    for (const ParamSpec& spec : paramSpecs(id)) {
      for (int i = 0; i < paramSize(spec.shape); ++i, ++k) {
        if (spec.kind == ParamKind::kReal) {
          c.names.push_back("extra." + flat[k]);
        } else {
          c.fixed.push_back({"extra." + flat[k], value[k]});
        }
      }
    }
    c.all_or_none = !c.fixed.empty();
    out.push_back(std::move(c));
  }
  return out;
}

namespace {

// One linearisation, gate, selection and joint refit, about the state `at` (its baseline
// coefficients; the candidates' parameters are zero there).
struct Pass {
  Linearised L;
  Selection sel;
  double scale = 1.0;
  double correlation = 1.0;        // effective-n factor in scale (correlationFactor)
  std::vector<std::string> names;  // what the refit varied
  RefitResult fit;
  ExplainResult gate;  // the gate's and the constancy test's verdicts (unseparable, rejected)
};

// For every candidate with variants (ExplainCandidateSpec::variants): the variant whose
// columns, off the baseline's and every other candidate's, fit most of the residual. Sets the
// spec's fixed values and its columns in L (linearise leaves them to this). Trying a few
// 2-parameter variants (at most 3 axes x harmonic_max_order) this way is
// far below the BIC's penalty in chance gain, and against the fullest model a variant is not
// picked for residual another effect (a table error) explains.
void chooseVariants(ExplainProblem* p, ExplainEvaluator* eval, const ExplainState& at,
                    Linearised* L) {
  for (std::size_t g = 0; g < p->candidates.size(); ++g) {
    ExplainCandidateSpec& spec = p->candidates[g];
    if (spec.variants.empty()) continue;
    std::vector<int> others;
    for (std::size_t h = 0; h < L->cands.size(); ++h) {
      if (h == g) continue;
      for (int j : L->cands[h].cols) others.push_back(j);
    }
    // The other candidates' column space (once), the residual off it.
    const Eigen::MatrixXd B = columnBasis(columnsOf(L->Cperp, others), 1e-9);
    const Eigen::VectorXd e = projectOff(B, L->rperp);
    Eigen::MatrixXd best_cols;
    std::vector<double> best_raw;
    double best_gain = -1.0;
    for (const ExplainCandidateSpec::Fixed& v : spec.variants) {
      std::vector<double> raw;
      const Eigen::MatrixXd S = eval->jacobian(withFixed(at, v), spec.names, &raw);
      const Eigen::MatrixXd Sp = projectOff(B, projectOff(L->Ub, S));
      const double gain = e.squaredNorm() - fitResidual(Sp, e).squaredNorm();
      if (gain > best_gain) {
        best_gain = gain;
        spec.fixed = v;
        best_cols = S;
        best_raw = raw;
      }
    }
    const std::vector<int>& cols = L->cands[g].cols;
    for (std::size_t k = 0; k < cols.size(); ++k) {
      L->C.col(cols[k]) = best_cols.col(static_cast<int>(k));
      L->raw_max[static_cast<std::size_t>(cols[k])] = best_raw[k];
    }
    const Eigen::MatrixXd P = projectOff(L->Ub, best_cols);
    for (std::size_t k = 0; k < cols.size(); ++k)
      L->Cperp.col(cols[k]) = P.col(static_cast<int>(k));
  }
}

Pass selectAndRefit(ExplainProblem* problem, const ExplainOptions& o, ExplainEvaluator* eval,
                    const ExplainState& at, double log_n, bool test_constancy) {
  Pass q;
  q.L = linearise(*problem, eval, at);
  chooseVariants(problem, eval, at, &q.L);
  const ExplainProblem& p = *problem;
  Linearised& L = q.L;
  const GateInput gate{&L.Jb, &p.baseline_names, &L.C, &L.Cperp, &L.raw_max};
  for (Candidate& c : L.cands) gateParameters(gate, o, &c);
  gatePairs(gate, o, &L.cands, &q.gate);
  for (Candidate& c : L.cands) {
    if (!c.all_or_none || c.status != GateStatus::kActive || c.active.size() == c.cols.size()) {
      continue;
    }
    c.status = GateStatus::kBaselineCollinear;
    c.held_note += "its parameters describe one term together and cannot be fitted in part; ";
  }
  const Selector selector(L.Cperp, L.rperp, &L.cands);
  std::vector<std::size_t> all;
  for (std::size_t g = 0; g < L.cands.size(); ++g) {
    if (L.cands[g].status == GateStatus::kActive) all.push_back(g);
  }
  q.scale = std::max(1.0, selector.chi2(all) / std::max(1, L.dof_b - selector.params(all)));
  {
    std::vector<int> cols;
    for (std::size_t g : all) {
      for (int j : L.cands[g].active) cols.push_back(j);
    }
    q.correlation = correlationFactor(fitResidual(columnsOf(L.Cperp, cols), L.rperp), *p.bins, o);
    q.scale *= q.correlation;
  }
  q.sel = selectEffects(selector, L.cands, q.scale, log_n);
  for (std::size_t round = 0; test_constancy && round < L.cands.size(); ++round) {
    std::string why;
    const std::size_t g = leastConstant(L, *p.bins, q.sel.accepted, q.scale, o, &why);
    if (g == std::string::npos) break;
    L.cands[g].status = GateStatus::kInconsistent;
    L.cands[g].inconsistent = why;
    q.sel = selectEffects(selector, L.cands, q.scale, log_n);
  }
  reportGate(L.cands, &q.gate);
  q.names = p.baseline_names;
  ExplainState start = at;
  for (std::size_t g : q.sel.accepted) {
    start = withFixed(start, p.candidates[g].fixed);
    for (int j : L.cands[g].active) {
      const std::string& n = L.cnames[static_cast<std::size_t>(j)];
      q.names.push_back(n);
      std::string why;
      setStateValue(&start, n, stateValue(at, n), &why);  // enables the effect in the state
    }
  }
  q.fit = refitJointly(eval, start, q.names, o.refit);
  return q;
}

// The refitted state with the accepted effects' parameters back at their start values: the
// baseline coefficients as the accepted effects left them.
ExplainState withoutCandidates(const Pass& q, const ExplainState& start) {
  ExplainState s = q.fit.state;
  for (std::size_t g : q.sel.accepted) {
    for (int j : q.L.cands[g].active) {
      const std::string& n = q.L.cnames[static_cast<std::size_t>(j)];
      std::string why;
      setStateValue(&s, n, stateValue(start, n), &why);
    }
  }
  return s;
}

}  // namespace

// Selection is on the problem linearised at the baseline. A large concealed effect moves the
// baseline calibration far from the truth (it absorbed what it could of the effect), and the
// linearisation there makes small candidates look significant; when a pass accepts anything,
// the analysis is repeated about the refitted baseline coefficients (candidates at zero), where
// the model is linear to far below the noise, and that pass is reported. The constancy test
// (leastConstant) runs in that pass only: about a biased baseline the linearisation error
// itself changes along the recording.
ExplainResult analyseProblem(const ExplainProblem& problem, const ExplainOptions& o) {
  ExplainProblem p = problem;  // its candidates' variants are chosen in each pass
  ExplainResult res;
  res.baseline_method = p.baseline_method;
  res.segments = p.segments;
  res.noise = p.noise;
  ExplainEvaluator eval(p.bins, p.forward, p.sigma, o.fd_step, o.threads);
  const double log_n = std::log(static_cast<double>(eval.rows()));
  std::vector<std::string> held_given;
  if (p.baseline_method == "given") held_given = undeterminedGiven(p, o, &eval);
  for (const std::string& n : held_given) {
    p.baseline_names.erase(std::find(p.baseline_names.begin(), p.baseline_names.end(), n));
  }
  Pass q = selectAndRefit(&p, o, &eval, p.start, log_n, o.passes == 1);
  const Linearised first = q.L;  // residuals before: about the given baseline
  res.baseline_normalised_rms = std::sqrt(first.rperp.squaredNorm() / std::max(1, first.dof_b));
  for (int pass = 1; pass < o.passes && q.fit.status.ok && !q.sel.accepted.empty(); ++pass) {
    q = selectAndRefit(&p, o, &eval, withoutCandidates(q, p.start), log_n, true);
  }
  if (!q.fit.status.ok) {
    res.status = q.fit.status;
    return res;
  }
  if (std::string why = givenMismatch(p, o, q.fit.state.model); !why.empty()) {
    res.status = Status::Error(std::move(why));
    return res;
  }
  res.scale = q.scale;
  res.correlation = q.correlation;
  res.unseparable = q.gate.unseparable;
  res.rejected = q.gate.rejected;
  res.notes = q.gate.notes;
  if (!held_given.empty()) {
    std::string names;
    for (const std::string& n : held_given) names += (names.empty() ? "" : ", ") + n;
    res.notes.push_back(
        "given coefficients held at their values (this recording cannot "
        "determine them to within the given-file tolerance): " +
        names);
  }
  res.refit = {q.fit.iterations, q.fit.converged, q.fit.last_step_sigma, q.fit.chi2_per_dof};
  if (!q.fit.converged) {
    char buf[240];
    std::snprintf(buf, sizeof(buf),
                  "the joint refit did not converge in %d iterations (its last step moved a "
                  "coefficient by %.3g sigma): the values may lie off the best fit",
                  q.fit.iterations, q.fit.last_step_sigma);
    res.notes.push_back(buf);
  }
  if (q.correlation > 1.0) {
    char buf[240];
    std::snprintf(buf, sizeof(buf),
                  "the residual is correlated from bin to bin (structure outside the model): "
                  "the tests count %.3g times fewer independent bins",
                  q.correlation);
    res.notes.push_back(buf);
  }
  const Selector selector(q.L.Cperp, q.L.rperp, &q.L.cands);
  reportSelection(p.candidates, q.L.cands, q.sel, selector, q.scale, log_n, q.names, q.fit, &res);
  finish(p, o, first, &eval, q.fit, q.names, &res);
  // An effect enabled only to evaluate a candidate's discrete variant and not accepted is not
  // part of the refitted coefficients.
  for (std::size_t g = 0; g < p.candidates.size(); ++g) {
    const std::optional<EffectId> id = effectFromName(p.candidates[g].id);
    const bool accepted =
        std::find(q.sel.accepted.begin(), q.sel.accepted.end(), g) != q.sel.accepted.end();
    if (id && !accepted && !p.start.model.extra.has(*id))
      res.coefficients.values.extra.disable(*id);
  }
  if (p.noise.anyResolutionLimited()) res.notes.insert(res.notes.begin(), explainVerdict(res));
  res.status = Status::Ok();
  return res;
}

namespace {

// The runs' navigation residuals at the coefficients m (sensors and table errors).
Result<std::vector<RunAttitudeResidual>> runResidualsAt(const ExplainInput& in,
                                                        const BenchTruth& m) {
  IndirectInput ii;
  ii.recording() = in.recording();
  ii.start = m.sensors;
  ii.start_base_tilt = m.table.base_tilt;
  ii.start_nonorthogonality = m.table.nonorthogonality;
  return indirectRunResiduals(ii, IndirectOptions{});
}

}  // namespace

// ExplainResult::runs: before at the baseline, after at the refit. Nothing when the recording
// has no run between two holds (or the method's checks refuse it).
std::vector<ExplainRunResidual> explainRunResiduals(const ExplainInput& in,
                                                    const BenchTruth& after) {
  const auto b = runResidualsAt(in, in.baseline.values);
  const auto a = runResidualsAt(in, after);
  std::vector<ExplainRunResidual> out;
  if (!b.ok() || !a.ok() || a.value.size() != b.value.size()) return out;
  for (std::size_t k = 0; k < b.value.size(); ++k) {
    const RunAttitudeResidual& rb = b.value[k];
    out.push_back({rb.label,
                   rb.t0,
                   rb.t1,
                   {rb.tilt_rad.x(), rb.tilt_rad.y()},
                   {a.value[k].tilt_rad.x(), a.value[k].tilt_rad.y()},
                   rb.sigma_rad});
  }
  return out;
}

// A note when the refitted coefficients navigate the runs clearly worse than the baseline's:
// the bins then constrain what the runs measure (gyro scales and misalignments) weakly, e.g.
// through the encoder samples' timing scatter, and the refit drifted along it.
std::string explainNavigationNote(const std::vector<ExplainRunResidual>& runs) {
  double chi2_before = 0.0, chi2_after = 0.0, ss_before = 0.0, ss_after = 0.0;
  for (const ExplainRunResidual& r : runs) {
    for (int k = 0; k < 2; ++k) {
      chi2_before += std::pow(r.before[static_cast<std::size_t>(k)] / r.sigma, 2);
      chi2_after += std::pow(r.after[static_cast<std::size_t>(k)] / r.sigma, 2);
      ss_before += std::pow(r.before[static_cast<std::size_t>(k)], 2);
      ss_after += std::pow(r.after[static_cast<std::size_t>(k)], 2);
    }
  }
  const double n = 2.0 * static_cast<double>(runs.size());
  // Worse by more than the noise could make it: 2x and 9 per residual (3 sigma).
  if (runs.empty() || chi2_after < 2.0 * chi2_before || chi2_after < 9.0 * n) return "";
  constexpr double kArcsec = 180.0 / kPi * 3600.0;
  char buf[400];
  std::snprintf(buf, sizeof(buf),
                "the refitted coefficients navigate the runs worse than the baseline's "
                "(attitude RMS %.3g -> %.3g arcsec): the bins constrain the gyro scales and "
                "misalignments weakly here (e.g. timing scatter of the encoder samples); keep "
                "the baseline coefficients and take only the accepted effects' values",
                std::sqrt(ss_before / n) * kArcsec, std::sqrt(ss_after / n) * kArcsec);
  return buf;
}

namespace {

// The effect axis (kTableAxisOuter / Middle / Inner) of spline a of ExplainData::axes.
int tableAxisOfSpline(TableKind kind, std::size_t a) {
  if (a == 0) return kTableAxisOuter;
  return kind == TableKind::kTwoAxis || a == 2 ? kTableAxisInner : kTableAxisMiddle;
}

}  // namespace

// angle_harmonic's variants (ExplainOptions::harmonic_*): every order on every axis that
// turns far enough. None when no axis does (the default variant is then not excited).
void addHarmonicVariants(const ExplainData& data, const ExplainOptions& o, ExplainProblem* p) {
  for (ExplainCandidateSpec& spec : p->candidates) {
    if (spec.id != "angle_harmonic" || spec.fixed.size() != 2) continue;
    for (std::size_t a = 0; a < data.axes.size(); ++a) {
      const std::vector<double>& v = data.axes[a].values();
      if (v.empty()) continue;
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      if (*hi - *lo < o.harmonic_min_turn_rad) continue;
      for (int k = 1; k <= o.harmonic_max_order; ++k) {
        ExplainCandidateSpec::Fixed f = spec.fixed;
        for (auto& [name, value] : f) {
          value = name.ends_with(".axis") ? tableAxisOfSpline(data.geometry.kind, a) : k;
        }
        if (std::find(spec.variants.begin(), spec.variants.end(), f) == spec.variants.end())
          spec.variants.push_back(std::move(f));
      }
    }
  }
}

std::vector<double> explainRowSigmas(const ExplainData& data, const NoiseFloor& noise) {
  return rowSigmas(data, noise);
}

std::vector<std::string> explainBaselineNames(const ExplainInput& input) {
  return baselineNamesOf(input);
}

std::vector<ExplainCandidateSpec> explainCandidates(const ExplainInput& input,
                                                    const ExplainOptions& options) {
  return candidateEffects(input, options);
}

std::string explainMotionRefusal(const RecordingView& recording) {
  const MotionSupport m = motionSupport(recording);
  if (m.determinesTriads()) return "";
  return "the motion cannot determine a calibration of this recording (" + m.describe() +
         "): " + m.missing() +
         "; record holds with each axis up and down and rotations about each axis (e.g. the "
         "bundled direct_two_axis plan), or give the coefficients (--coeffs)";
}

ExplainPart prepareExplainPart(const ExplainInput& in, const ExplainOptions& o) {
  ExplainPart part;
  if (std::string why = checkInput(in, o); !why.empty()) {
    part.status = Status::Error(std::move(why));
    return part;
  }
  const std::vector<HoldReadings> holds = staticHolds(in, o);
  if (std::string why = checkHolds(o, holds); !why.empty()) {
    part.status = Status::Error(std::move(why));
    return part;
  }
  if (in.baseline_method != "given" && in.baseline_from_this_recording) {
    // A baseline calibrated from a recording whose motion cannot determine it is noise fitted
    // to noise: refused before any analysis.
    if (std::string why = explainMotionRefusal(in.recording()); !why.empty()) {
      part.status = Status::Error(std::move(why));
      part.unusable = true;
      return part;
    }
  }
  // The noise floor and the bins are independent: side by side when there is a second thread.
  auto noise = std::async(o.threads > 1 ? std::launch::async : std::launch::deferred,
                          [&holds, &o] { return noiseFloor(holds, o.noise); });
  part.data = prepareExplainData(in.geometry, in.site, in.imu, in.table, in.segments, o.model);
  part.noise = noise.get();
  if (!part.noise.status.ok) {
    part.status = part.noise.status;
    return part;
  }
  if (part.data.bins.empty()) {
    part.status = Status::Error("no IMU sample lies within the span of the encoder samples");
    return part;
  }
  part.sigma = rowSigmas(part.data, part.noise, &part.model_sigma);
  return part;
}

std::pair<int, double> explainRecordingTime(const ExplainResult& r, double t) {
  int k = 0;
  while (k + 1 < static_cast<int>(r.recording_offsets_s.size()) &&
         t >= r.recording_offsets_s[static_cast<std::size_t>(k) + 1]) {
    ++k;
  }
  return {k, r.recording_offsets_s.empty()
                 ? t
                 : t - r.recording_offsets_s[static_cast<std::size_t>(k)]};
}

ExplainResult explainRecording(const ExplainInput& in, const ExplainOptions& o) {
  ExplainResult res;
  const ExplainPart part = prepareExplainPart(in, o);
  if (!part.status.ok) {
    res.status = part.status;
    res.unusable = part.unusable;
    return res;
  }
  ExplainPredictor predictor(&part.data);
  ExplainProblem p;
  p.noise = part.noise;
  p.bins = &part.data.bins;
  p.forward = &predictor;
  p.sigma = part.sigma;
  p.model_sigma = part.model_sigma;
  p.start.model = in.baseline.values;
  p.start.model.table_kind = in.geometry.kind;
  p.baseline_names = explainBaselineNames(in);
  p.candidates = explainCandidates(in, o);
  p.segments.assign(in.segments.begin(), in.segments.end());
  p.baseline_method = in.baseline_method;
  addHarmonicVariants(part.data, o, &p);
  res = analyseProblem(p, o);
  if (!res.status.ok) return res;
  res.runs = explainRunResiduals(in, res.coefficients.values);
  if (const std::string n = explainNavigationNote(res.runs); !n.empty()) res.notes.push_back(n);
  return res;
}

}  // namespace imubench::calib
