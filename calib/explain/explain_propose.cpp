#include "calib/explain/explain_propose.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include "calib/explain/explain_fit.h"
#include "calib/simulator.h"

namespace imubench::calib {
namespace {

constexpr double kDeg = kPi / 180.0;
// A predicted sigma the plan cannot bound (a parameter in a null direction) counts as this
// many decades above its target in the deficit: worse than any finite shortfall.
constexpr double kUnseenDecades = 6.0;

// ---- Groups ----------------------------------------------------------------------------

struct EffectColumns {
  std::string id;
  std::vector<std::string> names;  // flat names (columns)
  ExplainCandidateSpec::Fixed fixed;
};

struct Group {
  std::vector<std::size_t> effects;  // into the effect list
  bool unseparable = false;
  std::vector<double> target;  // per parameter of the effects (precision groups)
  // Unseparable on every candidate block together (e.g. a base tilt about the outer axis and
  // the outer encoder zero are one rotation on a two-axis table): no plan of them helps.
  std::string impossible;
};

std::size_t effectIndex(const std::string& id, const std::vector<ExplainCandidateSpec>& specs,
                        std::vector<EffectColumns>* effects) {
  for (std::size_t k = 0; k < effects->size(); ++k) {
    if ((*effects)[k].id == id) return k;
  }
  for (const ExplainCandidateSpec& s : specs) {
    if (s.id != id) continue;
    effects->push_back({s.id, s.names, s.fixed});
    return effects->size() - 1;
  }
  return std::numeric_limits<std::size_t>::max();
}

// An effect with discrete variants (angle_harmonic: axis and order) is judged at the variant
// each analysis finds best. Unseparable, its variant is arbitrary, and the analysis of the
// follow-up may judge another than the design evaluated: on the virtual bench a plan designed
// for one ran and was judged "still unseparable". No claim is made for such a group.
std::string variantReason(const std::string& id) {
  return "no plan within the bench limits can be designed for it with confidence: " + id +
         "'s variant (axis, order) is chosen by each analysis, and an unseparable one is "
         "arbitrary, so the analysis of a follow-up may judge another variant than the design "
         "evaluated";
}

// Unseparable pairs (the ones between two effects: an effect unseparable from the baseline is
// a single id) and accepted effects whose reported sigma is above the precision.
void listGroups(const ExplainInput& in, const ExplainResult& res, const ExplainOptions& eo,
                const ProposeOptions& po, std::vector<EffectColumns>* effects,
                std::vector<Group>* groups) {
  ExplainOptions all = eo;
  all.candidates.clear();
  const std::vector<ExplainCandidateSpec> specs = explainCandidates(in, all);
  // A pair (two effects sharing a direction) or one effect the baseline absorbs.
  for (const ExplainUnseparable& u : res.unseparable) {
    if (u.effects.empty() || u.effects.size() > 2) continue;
    Group g;
    g.unseparable = true;
    bool known = true;
    for (const std::string& id : u.effects) {
      g.effects.push_back(effectIndex(id, specs, effects));
      known = known && g.effects.back() < effects->size();
      // Discrete parameters held (fixed): the effect has variants.
      if (known && g.impossible.empty() && !(*effects)[g.effects.back()].fixed.empty()) {
        g.impossible = variantReason(id);
      }
    }
    if (known) groups->push_back(g);
  }
  for (const ExplainAccepted& a : res.accepted) {
    // Only the fitted parameters: one without a sigma is held in the refit (angle_harmonic's
    // axis and order, a parameter explain could not determine), and no plan gives it one.
    double norm = 0.0;
    for (std::size_t k = 0; k < a.values.size(); ++k) {
      if (std::isfinite(a.sigmas[k])) norm += a.values[k] * a.values[k];
    }
    const double target = po.relative_precision * std::sqrt(norm);
    bool short_of = false;
    for (double s : a.sigmas) short_of = short_of || (std::isfinite(s) && s > target);
    if (!short_of) continue;
    Group g;
    g.effects.push_back(effects->size());
    effects->push_back({a.effect, a.flat_names, {}});
    g.target.assign(a.flat_names.size(), target);
    groups->push_back(g);
  }
}

// ---- Candidate blocks --------------------------------------------------------------------

const char* axisName(TableKind kind, int axis) {
  if (axis == 0) return "outer";
  return kind == TableKind::kTwoAxis || axis == 2 ? "inner" : "middle";
}

ProposedStep moveTo(const std::vector<double>& angles_deg) {
  ProposedStep s;
  s.kind = ProposedStep::Kind::kMove;
  for (double a : angles_deg) s.angles_rad.push_back(a * kDeg);
  return s;
}

ProposedStep holdFor(double s_) {
  ProposedStep s;
  s.duration_s = s_;
  return s;
}

ProposedStep turn(int axis, double angle_deg, double rate) {
  ProposedStep s;
  s.kind = ProposedStep::Kind::kRotate;
  s.axis = axis;
  s.angle_rad = angle_deg * kDeg;
  s.rate_rad_s = rate;
  return s;
}

std::vector<double> pose(int n, int p, double a_deg) {
  std::vector<double> v(static_cast<std::size_t>(n), 0.0);
  if (p >= 0) v[static_cast<std::size_t>(p)] = a_deg;
  return v;
}

// Holds with each axis up and down, a turn each way about every table axis (and the outer
// one with the next axis at 90 deg: the third body axis on a two-axis table): what explain
// needs to calibrate the baseline from the proposed recording alone.
ProposedBlock baseBlock(TableKind kind, const ProposeOptions& o) {
  const int n = axisCount(kind);
  ProposedBlock b;
  b.purpose =
      "calibration base: holds with each IMU axis up and down and a turn each way about "
      "every table axis (the baseline coefficients, from this recording alone)";
  const double poses[6][2] = {{0, 0}, {90, 0}, {90, 90}, {90, 180}, {90, 270}, {180, 360}};
  for (const auto& p : poses) {
    std::vector<double> v = pose(n, -1, 0.0);
    v[static_cast<std::size_t>(n == 2 ? 0 : 1)] = p[0];
    v[static_cast<std::size_t>(n - 1)] = p[1];
    b.steps.push_back(moveTo(v));
    b.steps.push_back(holdFor(o.hold_s));
  }
  const double rate = o.run_rate_fraction * o.limits.max_rate_rad_s;
  for (int t = 0; t <= n; ++t) {
    const int axis = t < n ? t : 0;
    b.steps.push_back(moveTo(pose(n, t < n ? -1 : 1, 90.0)));
    b.steps.push_back(holdFor(o.hold_s));
    b.steps.push_back(turn(axis, 360.0, rate));
    b.steps.push_back(holdFor(o.hold_s));
    b.steps.push_back(turn(axis, -360.0, rate));
    b.steps.push_back(holdFor(o.hold_s));
  }
  return b;
}

std::string where(TableKind kind, int t, int p, double a_deg) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "the %s axis with the %s axis at %g deg", axisName(kind, t),
                axisName(kind, p), a_deg);
  return buf;
}

ProposedBlock runsBlock(TableKind kind, int t, int p, double a, const ProposeOptions& o) {
  const int n = axisCount(kind);
  const double rate = o.run_rate_fraction * o.limits.max_rate_rad_s;
  ProposedBlock b;
  b.purpose = "turns each way about " + where(kind, t, p, a) +
              " (axis perpendicularity, tilts and zeros seen along another direction)";
  b.steps = {moveTo(pose(n, p, a)), holdFor(o.hold_s),     turn(t, 360.0, rate),
             holdFor(o.hold_s),     turn(t, -360.0, rate), holdFor(o.hold_s)};
  return b;
}

ProposedBlock holdsBlock(TableKind kind, int t, int p, double a, const ProposeOptions& o) {
  const int n = axisCount(kind);
  ProposedBlock b;
  b.purpose = "holds at eight angles of " + where(kind, t, p, a) +
              " (encoder zeros, tilts and angle errors against gravity and the Earth rate)";
  for (int k = 0; k < 8; ++k) {
    std::vector<double> v = pose(n, p, a);
    v[static_cast<std::size_t>(t)] = 45.0 * k;
    b.steps.push_back(moveTo(v));
    b.steps.push_back(holdFor(o.hold_s));
  }
  return b;
}

ProposedBlock ratesBlock(TableKind kind, int t, int p, double a, const ProposeOptions& o) {
  const int n = axisCount(kind);
  const double fast = o.run_rate_fraction * o.limits.max_rate_rad_s;
  const double slow = o.slow_rate_fraction * o.limits.max_rate_rad_s;
  ProposedBlock b;
  b.purpose = "runs at two rates each way about " + where(kind, t, p, a) +
              " (rate-dependent terms: lever arm, size effect, delays, scale asymmetry)";
  b.steps = {moveTo(pose(n, p, a)), holdFor(o.hold_s), turn(t, 720.0, fast), holdFor(o.hold_s),
             turn(t, -720.0, fast), holdFor(o.hold_s), turn(t, 360.0, slow), holdFor(o.hold_s),
             turn(t, -360.0, slow), holdFor(o.hold_s)};
  return b;
}

ProposedBlock reversalsBlock(TableKind kind, int t, int p, double a, const ProposeOptions& o) {
  const int n = axisCount(kind);
  const double rate = o.run_rate_fraction * o.limits.max_rate_rad_s;
  ProposedBlock b;
  b.purpose = "180 deg reversals about " + where(kind, t, p, a) +
              " (holds on both sides of a half turn each way: zeros and biases against "
              "direction-dependent terms)";
  b.steps = {moveTo(pose(n, p, a)), holdFor(o.hold_s), turn(t, 180.0, rate),  holdFor(o.hold_s),
             turn(t, -180.0, rate), holdFor(o.hold_s), turn(t, -180.0, rate), holdFor(o.hold_s),
             turn(t, 180.0, rate),  holdFor(o.hold_s)};
  return b;
}

std::vector<ProposedBlock> candidateBlocks(TableKind kind, const ProposeOptions& o) {
  const int n = axisCount(kind);
  std::vector<ProposedBlock> out;
  for (int t = 0; t < n; ++t) {
    for (int p = 0; p < n; ++p) {
      if (p == t) continue;
      for (double a : {45.0, 90.0, 135.0}) out.push_back(runsBlock(kind, t, p, a, o));
      for (double a : {0.0, 90.0}) {
        out.push_back(holdsBlock(kind, t, p, a, o));
        out.push_back(ratesBlock(kind, t, p, a, o));
        out.push_back(reversalsBlock(kind, t, p, a, o));
      }
    }
  }
  return out;
}

// Position moves of about 180 deg are ambiguous (the validator refuses them): such a move is
// split at its middle. Angles are tracked through the turns.
ProposedPlan withWaypoints(const ProposedPlan& plan) {
  ProposedPlan out = plan;
  std::vector<double> at(static_cast<std::size_t>(axisCount(plan.kind)), 0.0);
  for (ProposedBlock& b : out.blocks) {
    std::vector<ProposedStep> steps;
    for (const ProposedStep& s : b.steps) {
      if (s.kind == ProposedStep::Kind::kRotate)
        at[static_cast<std::size_t>(s.axis)] += s.angle_rad;
      if (s.kind != ProposedStep::Kind::kMove) {
        steps.push_back(s);
        continue;
      }
      ProposedStep mid = s;
      bool split = false;
      for (std::size_t k = 0; k < at.size(); ++k) {
        const double d = std::remainder(s.angles_rad[k] - at[k], 2.0 * kPi);
        if (std::abs(d) > 170.0 * kDeg) {
          mid.angles_rad[k] = at[k] + 0.5 * d;
          split = true;
        }
        at[k] = s.angles_rad[k];
      }
      if (split) steps.push_back(mid);
      steps.push_back(s);
    }
    b.steps = std::move(steps);
  }
  return out;
}

ProposedPlan planOf(TableKind kind, const ProposeOptions& o, std::vector<ProposedBlock> blocks) {
  ProposedPlan p;
  p.kind = kind;
  p.max_rate_rad_s = o.limits.max_rate_rad_s;
  p.max_accel_rad_s2 = o.limits.max_accel_rad_s2;
  p.blocks = std::move(blocks);
  return withWaypoints(p);
}

// ---- Regressors of a motion ------------------------------------------------------------

struct Model {
  const ExplainInput* input;
  const ExplainOptions* eo;
  const NoiseFloor* noise;
  ExplainState state;              // the baseline, effects' discrete parameters set
  std::vector<std::string> names;  // baseline names, then every effect's
  int baseline_cols = 0;
};

Eigen::MatrixXd rowsOf(Model* m, const TableGeometry& geometry, std::span<const nav::ImuSample> imu,
                       std::span<const TableSample> table, std::span<const Segment> segments) {
  const ExplainData data =
      prepareExplainData(geometry, m->input->site, imu, table, segments, m->eo->model);
  if (data.bins.empty()) return Eigen::MatrixXd(0, static_cast<int>(m->names.size()));
  ExplainPredictor predictor(&data);
  ExplainEvaluator eval(&data.bins, &predictor, explainRowSigmas(data, *m->noise), m->eo->fd_step,
                        m->eo->threads);
  return eval.jacobian(m->state, m->names);
}

// The block's regressors: its plan expanded alone, simulated without noise at the baseline.
Result<Eigen::MatrixXd> blockRows(Model* m, const ProposedBlock& block, const ProposeOptions& o,
                                  const ProposalExpander& expand, double* duration) {
  const Result<Motion> motion = expand(planOf(m->input->geometry.kind, o, {block}));
  if (!motion.ok()) return Result<Eigen::MatrixXd>::Error(motion.status.message);
  *duration = motion.value.duration;
  SimulatorInput si;
  si.world.site = m->input->site;
  si.world.outer_axis_heading_rad = m->input->geometry.outer_axis_heading_rad;
  si.world.truth = m->input->baseline.values;
  si.world.truth.extra = EffectSet{};
  si.motion = motion.value;
  SimOptions so;
  so.imu_rate_hz = o.imu_rate_hz;
  so.table_rate_hz = o.table_rate_hz;
  const Simulation sim = simulate(si, so);
  if (!sim.status.ok) return Result<Eigen::MatrixXd>::Error(sim.status.message);
  TableGeometry g = m->input->geometry;
  return {Status::Ok(), rowsOf(m, g, sim.imu, sim.table, sim.segments)};
}

// ---- Separation and sigmas of a set of rows ----------------------------------------------

struct Assessment {
  std::vector<double> angle;               // per group (unseparable groups)
  std::vector<std::vector<double>> kept;   // per group, per active column: off-baseline part
  std::vector<std::vector<double>> sigma;  // per group, per parameter (all of its effects)
  std::vector<double> deficit;             // per group
};

Eigen::MatrixXd normalisedColumns(const Eigen::MatrixXd& M, const std::vector<int>& cols) {
  Eigen::MatrixXd Z(M.rows(), static_cast<int>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) {
    const Eigen::VectorXd z = M.col(cols[k]);
    Z.col(static_cast<int>(k)) = z / std::max(z.norm(), 1e-300);
  }
  return Z;
}

// explain's pair test (calib/explain/explain.cpp holdSharedWith): b's unit columns off a's space.
double principalAngle(const Eigen::MatrixXd& Cperp, const std::vector<int>& a,
                      const std::vector<int>& b) {
  if (a.empty() || b.empty()) return 0.0;
  Eigen::MatrixXd A = columnBasis(normalisedColumns(Cperp, a), 1e-9);
  if (A.cols() == 0) return 0.0;
  const Eigen::MatrixXd Z = normalisedColumns(Cperp, b);
  if (Z.norm() == 0.0) return 0.0;
  const Eigen::MatrixXd Zoff = Z - A * (A.transpose() * Z);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Zoff);
  const double s = svd.singularValues()(svd.singularValues().size() - 1);
  return std::asin(std::clamp(s, 0.0, 1.0));
}

// Predicted 1-sigma of every column: inverse information on normalised columns; a column with
// a component in a null direction is not bounded (infinity).
std::vector<double> predictedSigmas(const Eigen::MatrixXd& J) {
  const int n = static_cast<int>(J.cols());
  std::vector<double> out(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  if (J.rows() == 0) return out;
  const Eigen::VectorXd d = J.colwise().norm().transpose();
  Eigen::MatrixXd Jn = J;
  for (int j = 0; j < n; ++j) Jn.col(j) /= std::max(d(j), 1e-300);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Jn.transpose() * Jn);
  const Eigen::VectorXd& ev = es.eigenvalues();
  const double floor = 1e-10 * std::max(ev.maxCoeff(), 1e-300);
  for (int j = 0; j < n; ++j) {
    if (d(j) == 0.0) continue;
    double var = 0.0;
    bool unseen = false;
    for (int k = 0; k < n; ++k) {
      const double v = es.eigenvectors()(j, k);
      if (ev(k) <= floor) {
        unseen = unseen || std::abs(v) > 1e-3;
        continue;
      }
      var += v * v / ev(k);
    }
    if (!unseen) out[static_cast<std::size_t>(j)] = std::sqrt(var) / d(j);
  }
  return out;
}

struct Layout {
  std::vector<std::vector<int>> columns;  // per effect: its columns in the candidate matrix
  std::vector<std::vector<int>> active;   // per effect: the ones not held (see holdIntrinsic)
};

// Predicted sigmas of a group's parameters: the information of the baseline's and the group's
// active columns (what explain fits for it); a held parameter is NaN.
std::vector<double> groupSigmas(const Eigen::MatrixXd& J, int nb, const Group& g,
                                const Layout& lay) {
  std::vector<int> cols;
  cols.reserve(static_cast<std::size_t>(nb));
  for (int j = 0; j < nb; ++j) cols.push_back(j);
  for (std::size_t e : g.effects) {
    for (int j : lay.active[e]) cols.push_back(nb + j);
  }
  Eigen::MatrixXd Jg(J.rows(), static_cast<int>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) Jg.col(static_cast<int>(k)) = J.col(cols[k]);
  const std::vector<double> sig = predictedSigmas(Jg);
  std::vector<double> out;
  std::size_t next = static_cast<std::size_t>(nb);
  for (std::size_t e : g.effects) {
    for (int j : lay.columns[e]) {
      const bool active =
          std::find(lay.active[e].begin(), lay.active[e].end(), j) != lay.active[e].end();
      out.push_back(active ? sig[next++] : std::numeric_limits<double>::quiet_NaN());
    }
  }
  return out;
}

double groupDeficit(const Group& g, const Assessment& a, std::size_t k, double limit,
                    double collinear) {
  double d = 0.0;
  if (!g.impossible.empty()) return d;
  if (g.unseparable && g.effects.size() == 2) d += std::max(0.0, 1.0 - a.angle[k] / limit);
  for (double kept : a.kept[k]) d += std::max(0.0, 1.0 - kept / collinear);
  for (std::size_t p = 0; p < g.target.size(); ++p) {
    const double s = a.sigma[k][p];
    if (std::isnan(s)) continue;  // held (explain holds it too)
    d += std::isfinite(s) ? std::max(0.0, std::log10(s / g.target[p])) : kUnseenDecades;
  }
  return d;
}

Assessment assess(const Eigen::MatrixXd& J, int nb, const std::vector<Group>& groups,
                  const Layout& lay, double limit, double collinear) {
  Assessment a;
  const Eigen::MatrixXd Ub = columnBasis(J.leftCols(nb), 1e-7);
  const Eigen::MatrixXd C = J.rightCols(J.cols() - nb);
  const Eigen::MatrixXd Cperp = projectOff(Ub, C);
  for (std::size_t k = 0; k < groups.size(); ++k) {
    const Group& g = groups[k];
    a.angle.push_back(
        g.unseparable && g.effects.size() == 2
            ? principalAngle(Cperp, lay.active[g.effects[0]], lay.active[g.effects[1]])
            : 0.0);
    a.kept.emplace_back();
    a.sigma.emplace_back();
    for (std::size_t e : g.effects) {
      for (int j : lay.active[e]) {
        const double n = C.col(j).norm();
        a.kept.back().push_back(n > 0.0 ? Cperp.col(j).norm() / n : 0.0);
      }
    }
    a.sigma.back() = groupSigmas(J, nb, g, lay);
    if (g.unseparable && g.effects.size() == 1 && !a.kept.back().empty()) {
      const double m = *std::min_element(a.kept.back().begin(), a.kept.back().end());
      a.angle.back() = std::asin(std::clamp(m, 0.0, 1.0));
    }
    a.deficit.push_back(groupDeficit(g, a, k, limit, collinear));
  }
  return a;
}

double total(const Assessment& a) {
  double s = 0.0;
  for (double d : a.deficit) s += d;
  return s;
}

Eigen::MatrixXd stack(const Eigen::MatrixXd& top, const Eigen::MatrixXd& bottom) {
  Eigen::MatrixXd out(top.rows() + bottom.rows(), top.cols());
  out << top, bottom;
  return out;
}

}  // namespace

bool ProposeOptions::IsValid(std::string* why) const {
  if (limits.max_rate_rad_s > 0.0 && limits.max_accel_rad_s2 > 0.0 && relative_precision > 0.0 &&
      max_duration_s > 0.0 && hold_s > 0.0 && run_rate_fraction > 0.0 && run_rate_fraction <= 1.0 &&
      slow_rate_fraction > 0.0 && slow_rate_fraction < 1.0 && imu_rate_hz > 0.0 &&
      table_rate_hz > 0.0) {
    return true;
  }
  *why =
      "limits, relative_precision, max_duration_s, hold_s, sample rates > 0; rate fractions in "
      "(0, 1]";
  return false;
}

namespace {

// The model's columns: the baseline's names, then each effect's; the effects' discrete
// parameters set in the state.
Model modelOf(const ExplainInput& in, const ExplainResult& res, const ExplainOptions& eo,
              const std::vector<EffectColumns>& effects, Layout* lay) {
  Model m{&in, &eo, &res.noise, {}, explainBaselineNames(in), 0};
  m.state.model = in.baseline.values;
  m.state.model.table_kind = in.geometry.kind;
  m.baseline_cols = static_cast<int>(m.names.size());
  for (const EffectColumns& e : effects) {
    std::string why;
    for (const auto& [name, value] : e.fixed) setStateValue(&m.state, name, value, &why);
    lay->columns.emplace_back();
    for (const std::string& n : e.names) {
      lay->columns.back().push_back(static_cast<int>(m.names.size()) - m.baseline_cols);
      m.names.push_back(n);
    }
  }
  return m;
}

// Parameters no candidate motion moves off the baseline (e.g. an encoder zero the sensor
// misalignments absorb on any table motion): held, as explain's gate holds them, and named.
void holdIntrinsic(const Eigen::MatrixXd& J_all, int nb, const std::vector<EffectColumns>& effects,
                   double collinear, Layout* lay, std::vector<std::string>* notes) {
  const Eigen::MatrixXd Ub = columnBasis(J_all.leftCols(nb), 1e-7);
  const Eigen::MatrixXd C = J_all.rightCols(J_all.cols() - nb);
  const Eigen::MatrixXd Cperp = projectOff(Ub, C);
  lay->active.assign(effects.size(), {});
  for (std::size_t e = 0; e < effects.size(); ++e) {
    for (std::size_t k = 0; k < lay->columns[e].size(); ++k) {
      const int j = lay->columns[e][k];
      const double n = C.col(j).norm();
      if (n > 0.0 && Cperp.col(j).norm() >= collinear * n) {
        lay->active[e].push_back(j);
      } else {
        notes->push_back(effects[e].names[k] +
                         " mimics the baseline coefficients (or is not excited) on every "
                         "candidate motion: held, as explain holds it");
      }
    }
  }
}

// Groups no plan of the candidate blocks separates: their angle with every block at once.
void markImpossible(const Eigen::MatrixXd& J_all, int nb, const Layout& lay, double limit,
                    const ExplainOptions& eo, const std::vector<EffectColumns>& effects,
                    std::vector<Group>* groups) {
  const Assessment a = assess(J_all, nb, *groups, lay, limit, eo.baseline_collinear);
  for (std::size_t k = 0; k < groups->size(); ++k) {
    Group& g = (*groups)[k];
    if (!g.impossible.empty()) continue;  // decided when listed (variantReason)
    if (g.unseparable && g.effects.size() == 1 && lay.active[g.effects[0]].empty()) {
      g.impossible = "no plan within the bench limits separates it: " + effects[g.effects[0]].id +
                     " mimics the baseline coefficients on every candidate motion (it needs "
                     "another reference or a change of the set-up, not another plan)";
    }
    if (!g.unseparable || g.effects.size() != 2 || a.angle[k] >= limit) continue;
    char buf[400];
    std::snprintf(buf, sizeof(buf),
                  "no plan within the bench limits separates them: with every candidate block "
                  "together (runs, holds, two rates, reversals about every axis) their principal "
                  "angle is %.3g deg, below the limit %.3g deg; they change the readings the "
                  "same way on any motion of this table (%s and %s",
                  a.angle[k] / kDeg, limit / kDeg, effects[g.effects[0]].id.c_str(),
                  effects[g.effects[1]].id.c_str());
    g.impossible = std::string(buf) + " need another reference, not another plan)";
  }
}

struct Search {
  std::vector<ProposedBlock> chosen;
  std::vector<std::vector<std::size_t>> served;  // per group: indices into chosen
  Eigen::MatrixXd J;
  double duration = 0.0;
};

// Greedy: the block removing most deficit per second, within max_duration_s.
void greedy(const std::vector<ProposedBlock>& blocks, const std::vector<Eigen::MatrixXd>& rows,
            const std::vector<double>& dur, const std::vector<Group>& groups, const Layout& lay,
            int nb, double limit, const ExplainOptions& eo, double max_s, Search* s) {
  std::vector<bool> used(blocks.size(), false);
  s->served.assign(groups.size(), {});
  for (;;) {
    const Assessment now = assess(s->J, nb, groups, lay, limit, eo.baseline_collinear);
    if (total(now) <= 0.0) return;
    double best_gain = 0.0;
    std::size_t best = blocks.size();
    Assessment best_a;
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      if (used[b] || s->duration + dur[b] > max_s || rows[b].rows() == 0) continue;
      const Assessment a =
          assess(stack(s->J, rows[b]), nb, groups, lay, limit, eo.baseline_collinear);
      const double gain = (total(now) - total(a)) / dur[b];
      if (gain > best_gain * (1.0 + 1e-9) && total(now) - total(a) > 1e-6) {
        best_gain = gain;
        best = b;
        best_a = a;
      }
    }
    if (best == blocks.size()) return;
    used[best] = true;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (best_a.deficit[k] < now.deficit[k] - 1e-9) s->served[k].push_back(s->chosen.size());
    }
    s->chosen.push_back(blocks[best]);
    s->chosen.back().duration_s = dur[best];
    s->J = stack(s->J, rows[best]);
    s->duration += dur[best];
  }
}

std::string shortfall(const Group& g, const Assessment& a, std::size_t k, double limit,
                      const std::vector<EffectColumns>& effects) {
  char buf[200];
  if (!g.impossible.empty()) return g.impossible;
  if (g.unseparable && g.effects.size() == 2 && a.angle[k] < limit) {
    std::snprintf(buf, sizeof(buf), "principal angle %.3g deg, limit %.3g deg", a.angle[k] / kDeg,
                  limit / kDeg);
    return std::string(buf) + ": " + effects[g.effects[0]].id + " and " + effects[g.effects[1]].id +
           " stay unseparable";
  }
  if (a.deficit[k] > 0.0 && g.unseparable && g.effects.size() == 1) {
    return effects[g.effects[0]].id + " stays unseparable from the baseline coefficients";
  }
  if (a.deficit[k] > 0.0) return "a predicted sigma stays above the requested precision";
  return "";
}

void fillGroups(const std::vector<Group>& groups, const std::vector<EffectColumns>& effects,
                const Assessment& before, const Assessment& after, const Assessment* joint,
                const Search& s, double limit, ProposeResult* r) {
  for (std::size_t k = 0; k < groups.size(); ++k) {
    const Group& g = groups[k];
    ProposedGroup out;
    out.unseparable = g.unseparable;
    for (std::size_t e : g.effects) {
      out.effects.push_back(effects[e].id);
      for (const std::string& n : effects[e].names) out.flat_names.push_back(n);
    }
    out.angle_before_rad = before.angle[k];
    out.angle_after_rad = after.angle[k];
    out.sigma_before = before.sigma[k];
    out.sigma_after = after.sigma[k];
    if (joint != nullptr) out.sigma_joint = joint->sigma[k];
    out.sigma_target = g.target;
    for (std::size_t b : s.served[k]) {
      out.added.push_back(s.chosen[b].purpose);
      out.added_duration_s += s.chosen[b].duration_s;
    }
    out.possible = g.impossible.empty();
    out.why = shortfall(g, after, k, limit, effects);
    out.resolved = out.why.empty();
    r->groups.push_back(std::move(out));
  }
}

// Not even the calibration base fits in max_duration_s: no plan; every group as it was.
void baseTooLong(const std::vector<Group>& groups, const std::vector<EffectColumns>& effects,
                 const Assessment& before, double base_s, double max_s, ProposeResult* r) {
  Search none;
  none.served.assign(groups.size(), {});
  fillGroups(groups, effects, before, before, nullptr, none, r->angle_limit_rad, r);
  char buf[200];
  std::snprintf(buf, sizeof(buf),
                "the calibration base alone takes %.0f s, more than the %.0f s allowed: no plan",
                base_s, max_s);
  for (ProposedGroup& g : r->groups) {
    if (!g.possible) continue;
    std::string names;
    for (const std::string& e : g.effects) names += (names.empty() ? "" : " and ") + e;
    g.resolved = false;
    g.why = std::string(buf) + "; " + names +
            (!g.unseparable         ? " stays short of the precision"
             : g.effects.size() > 1 ? " stay unseparable"
                                    : " stays unseparable");
  }
  r->notes.push_back(buf);
}

// The base and the candidates expanded, simulated and differentiated once each (the base is
// blocks[0]).
Status evaluateBlocks(Model* m, const ProposeOptions& po, const ProposalExpander& expand,
                      std::vector<ProposedBlock>* blocks, std::vector<Eigen::MatrixXd>* rows,
                      std::vector<double>* dur) {
  const TableKind kind = m->input->geometry.kind;
  *blocks = candidateBlocks(kind, po);
  blocks->insert(blocks->begin(), baseBlock(kind, po));
  dur->assign(blocks->size(), 0.0);
  for (std::size_t b = 0; b < blocks->size(); ++b) {
    Result<Eigen::MatrixXd> x = blockRows(m, (*blocks)[b], po, expand, &(*dur)[b]);
    if (!x.ok()) {
      return Status::Error("generated block '" + (*blocks)[b].purpose + "': " + x.status.message);
    }
    rows->push_back(std::move(x.value));
  }
  return Status::Ok();
}

}  // namespace

ProposeResult proposePlan(const ExplainInput& in, const ExplainResult& res,
                          const ExplainOptions& eo, const ProposeOptions& po,
                          const ProposalExpander& expand) {
  ProposeResult r;
  std::string why;
  if (!po.IsValid(&why)) {
    r.status = Status::Error("propose options: " + why);
    return r;
  }
  if (!res.status.ok) {
    r.status = Status::Error("no analysis to propose from: " + res.status.message);
    return r;
  }
  std::vector<EffectColumns> effects;
  std::vector<Group> groups;
  listGroups(in, res, eo, po, &effects, &groups);
  r.angle_limit_rad = std::acos(eo.unseparable_cos);
  r.baseline_angle_limit_rad = std::asin(eo.baseline_collinear);
  r.status = Status::Ok();
  if (groups.empty()) {
    r.nothing_to_propose = true;
    return r;
  }
  Layout lay;
  Model m = modelOf(in, res, eo, effects, &lay);
  const int nb = m.baseline_cols;
  std::vector<ProposedBlock> blocks;
  std::vector<Eigen::MatrixXd> rows;
  std::vector<double> dur;
  if (Status st = evaluateBlocks(&m, po, expand, &blocks, &rows, &dur); !st.ok) {
    r.status = st;
    return r;
  }
  Eigen::MatrixXd all(0, static_cast<int>(m.names.size()));
  for (const Eigen::MatrixXd& x : rows) all = stack(all, x);
  holdIntrinsic(all, nb, effects, eo.baseline_collinear, &lay, &r.notes);
  markImpossible(all, nb, lay, r.angle_limit_rad, eo, effects, &groups);
  const Eigen::MatrixXd J_rec = rowsOf(&m, in.geometry, in.imu, in.table, in.segments);
  const Assessment before =
      assess(J_rec, nb, groups, lay, r.angle_limit_rad, eo.baseline_collinear);
  if (dur[0] > po.max_duration_s) {
    baseTooLong(groups, effects, before, dur[0], po.max_duration_s, &r);
    return r;
  }
  Search s;
  s.chosen.push_back(blocks[0]);
  s.chosen.back().duration_s = dur[0];
  s.J = rows[0];
  s.duration = dur[0];
  const std::vector<ProposedBlock> cands(blocks.begin() + 1, blocks.end());
  const std::vector<Eigen::MatrixXd> cand_rows(rows.begin() + 1, rows.end());
  const std::vector<double> cand_dur(dur.begin() + 1, dur.end());
  greedy(cands, cand_rows, cand_dur, groups, lay, nb, r.angle_limit_rad, eo, po.max_duration_s, &s);
  const Assessment base =
      assess(rows[0], nb, groups, lay, r.angle_limit_rad, eo.baseline_collinear);
  for (std::size_t k = 0; k < groups.size(); ++k) {
    if (base.deficit[k] < before.deficit[k] - 1e-9) s.served[k].insert(s.served[k].begin(), 0);
  }
  const Assessment after = assess(s.J, nb, groups, lay, r.angle_limit_rad, eo.baseline_collinear);
  const Assessment joint =
      assess(stack(J_rec, s.J), nb, groups, lay, r.angle_limit_rad, eo.baseline_collinear);
  fillGroups(groups, effects, before, after, &joint, s, r.angle_limit_rad, &r);
  if (std::all_of(groups.begin(), groups.end(),
                  [](const Group& g) { return !g.impossible.empty(); })) {
    r.notes.push_back("no group can be separated by a plan of this table: no plan proposed");
    return r;
  }
  r.plan = planOf(in.geometry.kind, po, s.chosen);
  r.plan.description = "explain's proposal: separates what the analysed recording could not";
  const Result<Motion> full = expand(r.plan);
  if (!full.ok()) {
    r.status = Status::Error("the proposed plan: " + full.status.message);
    return r;
  }
  r.duration_s = full.value.duration;
  return r;
}

}  // namespace imubench::calib
