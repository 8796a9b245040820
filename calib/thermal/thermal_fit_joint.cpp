// The joint thermal fit from the direct calibration's raw rows (calib/thermal/thermal_fit.h
// fitThermalJoint): every row at its own temperature, the coefficients' polynomials by block
// Gauss-Seidel with BIC per coefficient, the table's errors (constant over temperature) as
// extra unknowns through the one chain, and the gate.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

#include "calib/thermal/thermal_fit.h"
#include "calib/thermal/thermal_fit_detail.h"
#include "calib/thermal_model.h"

namespace imubench::calib {
namespace {

using thermal_detail::CoefficientData;
using thermal_detail::distinctTemperatures;
using thermal_detail::fitCoefficient;
using thermal_detail::FitContext;

// Step of the difference that gives a row input's derivative by a table error, rad (0.2
// arcsec): the inputs are smooth in the errors, and 1e-6 keeps round-off at 1e-10 of g.
constexpr double kTableStep = 1e-6;
constexpr double kArcsec = kPi / (180.0 * 3600.0);

// One row of the joint fit: the direct calibration's row at its temperature.
struct JointRow {
  Vec3 input, reading, se;
  double dT = 0.0, rate = 0.0;  // T - t_ref, degC; Tdot, degC/s
  std::string where;            // "static 'hold-3' (DIR, 23.4 degC)", for messages
  std::vector<Vec3> dinput;     // d input / d table error, per JointData::params entry
};

struct JointData {
  std::vector<JointRow> accel, gyro;
  std::vector<double> temps;        // every row's T
  std::vector<std::string> params;  // table errors (flat names) the rows' dinput follow
  // Each run's observations in order: (accel row?, index), to refresh the inputs.
  std::vector<std::vector<std::pair<bool, std::size_t>>> order;
};

// The direct calibration's rows of a run with the table at `table`; false + why.
bool observe(const ThermalRun& run, const ThermalJointFitOptions& o, const TableErrors& table,
             DirectObservations* obs, std::string* why) {
  DirectCalibrationOptions d = o.direct;
  d.known_table_errors = table;
  *obs = directObservations(run.input, d);
  if (!obs->status.ok) *why = run.source + ": " + obs->status.message;
  return obs->status.ok;
}

// The recording with every k consecutive increments summed into one (t: the last one's): the
// table samples, segments and the rows' inputs stay (a static row's input is the chain at its
// mean encoder angles), at 1/k of the cost of building the rows.
DirectCalibrationInput decimated(const DirectCalibrationInput& in, std::size_t k) {
  DirectCalibrationInput out = in;
  out.imu.clear();
  for (std::size_t i = 0; i + k <= in.imu.size(); i += k) {
    nav::ImuSample s = in.imu[i + k - 1];
    for (std::size_t j = i; j + 1 < i + k; ++j) {
      s.dtheta += in.imu[j].dtheta;
      s.dvel += in.imu[j].dvel;
    }
    out.imu.push_back(s);
  }
  return out;
}

// d input / d table error of every row of `run` (rows in d->order[r]) by a difference through
// the chain; at about 5 Hz (decimated) when the rows stay the same there: the derivatives only
// steer the Gauss-Newton steps and the observability check, the inputs themselves are exact.
bool inputDerivatives(const ThermalRun& run, std::size_t r, const ThermalJointFitOptions& o,
                      const BenchTruth& table, JointData* d, std::string* why) {
  const auto& order = d->order[r];
  const nav::ImuSamples& imu = run.input.imu;
  const double rate = imu.size() > 1 ? (imu.size() - 1) / (imu.back().t - imu.front().t) : 0.0;
  const std::size_t k =
      std::isfinite(rate) && rate > 10.0 ? static_cast<std::size_t>(rate / 5.0) : 1;
  ThermalRun coarse{k > 1 ? decimated(run.input, k) : run.input, run.source};
  DirectObservations base;
  if (!observe(coarse, o, table.table, &base, why)) return false;
  if (base.rows.size() != order.size()) {
    if (k == 1) {
      *why = run.source + ": the rows changed with the table errors";
      return false;
    }
    coarse.input = run.input;
    if (!observe(coarse, o, table.table, &base, why)) return false;
  }
  for (std::size_t p = 0; p < d->params.size(); ++p) {
    BenchTruth moved = table;
    const double v = flatValue(table, d->params[p]).value_or(0.0);
    setFlatValue(&moved, d->params[p], v + kTableStep, why);
    DirectObservations obs;
    if (!observe(coarse, o, moved.table, &obs, why)) return false;
    if (obs.rows.size() != order.size()) {
      *why = run.source + ": the rows changed with " + d->params[p];
      return false;
    }
    for (std::size_t q = 0; q < order.size(); ++q) {
      JointRow& row = order[q].first ? d->accel[order[q].second] : d->gyro[order[q].second];
      row.dinput[p] = (obs.rows[q].input - base.rows[q].input) / kTableStep;
    }
  }
  return true;
}

// Sets every row's input of run r with the table at `table`, through the chain of
// directObservations, and (derivatives) its derivative by each of d->params; false + why. The
// derivatives change with the table errors only at second order (their products, ~1e-4 of
// themselves): taken once, they leave the outer iterations' convergence fast and the inputs,
// recomputed every time, exact.
bool refreshInputs(const ThermalRun& run, std::size_t r, const ThermalJointFitOptions& o,
                   const BenchTruth& table, bool derivatives, JointData* d, std::string* why) {
  DirectObservations base;
  if (!observe(run, o, table.table, &base, why)) return false;
  const auto& order = d->order[r];
  if (base.rows.size() != order.size()) {
    *why = run.source + ": the rows changed with the table errors";
    return false;
  }
  for (std::size_t k = 0; k < order.size(); ++k) {
    JointRow& row = order[k].first ? d->accel[order[k].second] : d->gyro[order[k].second];
    row.input = base.rows[k].input;
    if (derivatives) row.dinput.assign(d->params.size(), Vec3::Zero());
  }
  return !derivatives || d->params.empty() || inputDerivatives(run, r, o, table, d, why);
}

// Rows of one run with their mean IMU temperature and rate (inputs set by refreshInputs);
// false + why.
bool jointRows(const ThermalRun& run, const ThermalJointFitOptions& o, const BenchTruth& table,
               JointData* d, std::vector<std::string>* notes, std::string* why) {
  const nav::ImuSamples& imu = run.input.imu;
  if (std::none_of(imu.begin(), imu.end(),
                   [](const nav::ImuSample& s) { return std::isfinite(s.temp_c); })) {
    *why = run.source + ": the recording has no IMU temperatures (imu.csv temp column empty)";
    return false;
  }
  DirectObservations obs;
  if (!observe(run, o, table.table, &obs, why)) return false;
  for (const std::string& n : obs.notes) notes->push_back(run.source + ": " + n);
  const std::vector<double> rates = temperatureRates(imu, o.rate);
  d->order.emplace_back();
  for (const DirectObservation& ob : obs.rows) {
    auto it = std::lower_bound(imu.begin(), imu.end(), ob.t0,
                               [](const nav::ImuSample& a, double t) { return a.t < t; });
    double sum = 0.0, sum_rate = 0.0;
    std::size_t n = 0;
    for (; it != imu.end() && it->t <= ob.t1; ++it, ++n) {
      sum += it->temp_c;
      sum_rate += rates[static_cast<std::size_t>(it - imu.begin())];
    }
    if (n == 0 || !std::isfinite(sum)) {
      *why = run.source + ": segment '" + ob.label +
             "' has samples without temperature (imu.csv temp empty)";
      return false;
    }
    const double T = sum / static_cast<double>(n);
    char where[96];
    std::snprintf(where, sizeof(where), " (%.1f degC)", T);
    JointRow r{ob.input,
               ob.reading,
               ob.reading_se,
               T - o.fit.t_ref_c,
               sum_rate / static_cast<double>(n),
               std::string(ob.rotation ? "rotation '" : "static '") + ob.label + "' of " +
                   run.source + where,
               {}};
    auto& rows = ob.accel ? d->accel : d->gyro;
    d->order.back().emplace_back(ob.accel, rows.size());
    rows.push_back(std::move(r));
    d->temps.push_back(T);
  }
  return refreshInputs(run, d->order.size() - 1, o, table, true, d, why);
}

// The model's reading of a row with the triad at the row's temperature and rate.
Vec3 modelReading(const model::ThermalTriad& t, const JointRow& r, const Vec3& input) {
  std::array<double, model::kTriadSize> b{};
  for (int i = 0; i < model::kTriadSize; ++i) {
    b[static_cast<std::size_t>(i)] =
        model::thermalValue(t[static_cast<std::size_t>(i)], r.dT, r.rate);
  }
  return model::reading(b.data(), input);
}

Vec3 modelReading(const model::ThermalTriad& t, const JointRow& r) {
  return modelReading(t, r, r.input);
}

// d reading / d block[j] of a row (eq. 1 is linear in each entry alone: a unit difference is
// exact).
Vec3 entryGain(const model::ThermalTriad& t, const JointRow& r, int j) {
  model::ThermalTriad moved = t;
  moved[static_cast<std::size_t>(j)].poly[0] += 1.0;
  return modelReading(moved, r) - modelReading(t, r);
}

// Largest move of a coefficient's terms in its sigmas (infinite when its model changed).
double movement(const model::ThermalCoefficient& a, const model::ThermalCoefficient& b) {
  if (a.order != b.order || a.hysteresis != b.hysteresis)
    return std::numeric_limits<double>::infinity();
  double m = 0.0;
  for (int k = 0; k <= b.order; ++k) {
    const std::size_t u = static_cast<std::size_t>(k);
    if (b.sigma_poly[u] > 0.0) m = std::max(m, std::abs(a.poly[u] - b.poly[u]) / b.sigma_poly[u]);
  }
  if (b.hysteresis && b.sigma_dTdt > 0.0) m = std::max(m, std::abs(a.dTdt - b.dTdt) / b.sigma_dTdt);
  return m;
}

// Entry j's data with the other entries held at t: the residual of its axis plus its own
// current contribution, and its gain.
CoefficientData entryData(const model::ThermalTriad& t, const std::vector<JointRow>& rows, int j,
                          double sigma_floor) {
  std::vector<Vec3> gains;
  Vec3 total = Vec3::Zero();
  for (const JointRow& r : rows) {
    gains.push_back(entryGain(t, r, j));
    total += gains.back().cwiseAbs();
  }
  int axis = 0;
  total.maxCoeff(&axis);
  CoefficientData d;
  const model::ThermalCoefficient& c = t[static_cast<std::size_t>(j)];
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const JointRow& r = rows[i];
    const double g = gains[i][axis];
    d.dT.push_back(r.dT);
    d.rate.push_back(r.rate);
    d.gain.push_back(g);
    d.value.push_back(r.reading[axis] - modelReading(t, r)[axis] +
                      g * model::thermalValue(c, r.dT, r.rate));
    d.sigma.push_back(std::max(r.se[axis], sigma_floor));
  }
  return d;
}

// Block Gauss-Seidel over the entries of one triad (warm: from *t, else from the ideal
// sensor); false + why.
bool fitTriadJoint(const std::vector<JointRow>& rows, const FitContext& ctx,
                   const ThermalJointFitOptions& o, const std::string& name, model::ThermalTriad* t,
                   std::vector<ThermalCoefficientFit>* fits, int* sweeps, bool warm,
                   std::string* why) {
  for (int j = 0; j < model::kTriadSize && !warm; ++j) {
    (*t)[static_cast<std::size_t>(j)] = {};
    (*t)[static_cast<std::size_t>(j)].poly[0] = j < model::kBias ? 1.0 : 0.0;
  }
  std::vector<ThermalCoefficientFit> f(model::kTriadSize);
  // Smallest sigma of a row's mean: the direct calibration's (below it a residual is
  // round-off; noise-free recordings would otherwise get infinite weights).
  const double floor =
      name == "accel" ? o.direct.accel_residual_floor : o.direct.gyro_residual_floor;
  for (*sweeps = 1; *sweeps <= o.max_sweeps; ++*sweeps) {
    double moved = 0.0;
    for (int j = 0; j < model::kTriadSize; ++j) {
      const std::size_t u = static_cast<std::size_t>(j);
      const CoefficientData d = entryData(*t, rows, j, floor);
      model::ThermalCoefficient next;
      f[u] = {};
      f[u].name = thermalCoefficientName(name, j);
      if (!fitCoefficient(d, ctx, &next, &f[u], why)) return false;
      moved = std::max(moved, movement((*t)[u], next));
      (*t)[u] = next;
    }
    if (moved <= o.tolerance) break;
  }
  *sweeps = std::min(*sweeps, o.max_sweeps);
  fits->insert(fits->end(), f.begin(), f.end());
  return true;
}

// ---- Which table errors the rows determine ------------------------------------------------

double floorOf(const ThermalJointFitOptions& o, bool accel) {
  return accel ? o.direct.accel_residual_floor : o.direct.gyro_residual_floor;
}

// The ideal sensor (scale 1, nothing else): what the observability check linearises at.
model::ThermalTriad idealTriad() {
  model::ThermalTriad t{};
  for (int j = 0; j < model::kBias; ++j) t[static_cast<std::size_t>(j)].poly[0] = 1.0;
  return t;
}

// Weighted columns, one equation per row and axis: C the coefficients' constant and linear
// terms (both triads, ideal sensor), T each table error of d.params.
void observabilityDesign(const JointData& d, const ThermalJointFitOptions& o, double scale,
                         Eigen::MatrixXd* C, Eigen::MatrixXd* T) {
  const Eigen::Index m = static_cast<Eigen::Index>(3 * (d.accel.size() + d.gyro.size()));
  C->setZero(m, Eigen::Index{4} * model::kTriadSize);
  T->setZero(m, static_cast<Eigen::Index>(d.params.size()));
  const model::ThermalTriad ideal = idealTriad();
  Eigen::Index e = 0;
  for (const int tri : {0, 1}) {
    for (const JointRow& r : tri == 0 ? d.accel : d.gyro) {
      for (int a = 0; a < 3; ++a, ++e) {
        const double w = 1.0 / std::max(r.se[a], floorOf(o, tri == 0));
        for (int j = 0; j < model::kTriadSize; ++j) {
          const double g = entryGain(ideal, r, j)[a];
          const Eigen::Index col = Eigen::Index{2} * (tri * model::kTriadSize + j);
          (*C)(e, col) = w * g;
          (*C)(e, col + 1) = w * g * r.dT / scale;
        }
        for (std::size_t p = 0; p < d.params.size(); ++p) {
          (*T)(e, static_cast<Eigen::Index>(p)) = w * r.dinput[p][a];
        }
      }
    }
  }
}

// Orthonormal basis of the column space of C (columns normalised first; rank revealing).
Eigen::MatrixXd orthonormalBasis(Eigen::MatrixXd C) {
  for (Eigen::Index k = 0; k < C.cols(); ++k) {
    const double n = C.col(k).norm();
    if (n > 0.0) C.col(k) /= n;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(C);
  qr.setThreshold(1e-10);
  const Eigen::Index rank = qr.rank();
  Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(C.rows(), rank);
  return Q;
}

// v without its components along the orthonormal columns of B (twice: Gram-Schmidt's loss of
// orthogonality).
Eigen::VectorXd orthogonalPart(const Eigen::MatrixXd& B, Eigen::VectorXd v) {
  for (int pass = 0; pass < 2; ++pass) v -= B * (B.transpose() * v);
  return v;
}

std::string arcsec(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f arcsec", rad / kArcsec);
  return buf;
}

// Why table error p is held: the table error already taken it cannot be told from, the
// coefficients absorbing it, or too little information.
std::string heldReason(const Eigen::MatrixXd& coef_basis, const Eigen::MatrixXd& T,
                       const std::vector<std::size_t>& taken, std::size_t p, double sigma,
                       const std::vector<std::string>& names, const BenchTruth& held,
                       const ThermalJointFitOptions& o) {
  const std::string at = ": held at " + arcsec(flatValue(held, names[p]).value_or(0.0));
  const Eigen::VectorXd rc = orthogonalPart(coef_basis, T.col(static_cast<Eigen::Index>(p)));
  const double n = T.col(static_cast<Eigen::Index>(p)).norm();
  for (const std::size_t q : taken) {
    const Eigen::VectorXd rq = orthogonalPart(coef_basis, T.col(static_cast<Eigen::Index>(q)));
    if (rc.norm() > 0.0 && rq.norm() > 0.0 && std::abs(rc.dot(rq)) > 0.9 * rc.norm() * rq.norm()) {
      return names[p] + " is indistinguishable from " + names[q] + " with this motion (the " +
             names[q] + " estimate holds both)" + at;
    }
  }
  if (n == 0.0 || rc.squaredNorm() <= o.min_table_information * n * n) {
    return names[p] +
           " is indistinguishable from the sensor coefficients (both triads' misalignments "
           "absorb it: they refer to the platform)" +
           at;
  }
  return names[p] + " is determined by this motion only to " + arcsec(sigma) + " (limit " +
         arcsec(o.max_table_sigma_rad) + ")" + at;
}

// Indices into names of the table errors the rows determine; why each other one is held
// into notes.
std::vector<std::size_t> observableTable(const Eigen::MatrixXd& C, const Eigen::MatrixXd& T,
                                         const std::vector<std::string>& names,
                                         const BenchTruth& held, const ThermalJointFitOptions& o,
                                         std::vector<std::string>* notes) {
  const Eigen::MatrixXd coef_basis = orthonormalBasis(C);
  Eigen::MatrixXd basis = coef_basis;
  std::vector<std::size_t> taken;
  for (std::size_t p = 0; p < names.size(); ++p) {
    const Eigen::VectorXd col = T.col(static_cast<Eigen::Index>(p));
    const Eigen::VectorXd res = orthogonalPart(basis, col);
    const double r2 = res.squaredNorm();
    const double sigma = r2 > 0.0 ? 1.0 / std::sqrt(r2) : std::numeric_limits<double>::infinity();
    if (r2 > o.min_table_information * col.squaredNorm() && sigma <= o.max_table_sigma_rad) {
      taken.push_back(p);
      basis.conservativeResize(Eigen::NoChange, basis.cols() + 1);
      basis.col(basis.cols() - 1) = res / std::sqrt(r2);
      continue;
    }
    notes->push_back(heldReason(coef_basis, T, taken, p, sigma, names, held, o));
  }
  return taken;
}

// Keeps only the table errors `keep` (indices into d->params) in d.
void keepParams(const std::vector<std::size_t>& keep, JointData* d) {
  std::vector<std::string> names;
  names.reserve(keep.size());
  for (const std::size_t p : keep) names.push_back(d->params[p]);
  for (auto* rows : {&d->accel, &d->gyro}) {
    for (JointRow& r : *rows) {
      std::vector<Vec3> di;
      di.reserve(keep.size());
      for (const std::size_t p : keep) di.push_back(r.dinput[p]);
      r.dinput = std::move(di);
    }
  }
  d->params = std::move(names);
}

// ---- The joint step over every polynomial term and the table errors -----------------------

// Terms of a coefficient: poly[0..order], then its dT/dt term.
int termCount(const model::ThermalCoefficient& c) {
  return c.order + 1 + (c.hysteresis ? 1 : 0);
}

struct JointStep {
  Eigen::VectorXd dtable, sigma_table;  // Gauss-Newton step of the table errors, their sigmas
  Eigen::VectorXd coef_sigma;           // marginal sigma of every term (physical units)
  std::array<double, 2> nrms{};         // normalised residual RMS, accel and gyro
  std::vector<std::pair<double, std::string>> rows;  // each row's normalised residual
};

// The weighted Jacobian J (terms scaled as in fitCoefficient, then the table errors) and
// residual b of every row and axis at the coefficients c; per-triad chi2 and parameter count.
struct JointSystem {
  Eigen::MatrixXd J;
  Eigen::VectorXd b;
  std::array<double, 2> chi2{};
  std::array<int, 2> equations{}, params{};
  int coef_terms = 0;
  std::vector<std::pair<double, std::string>> rows;
};

void addRowEquations(const JointRow& r, const model::ThermalTriad& t, int tri, int first,
                     int coef_terms, const FitContext& ctx, double floor, Eigen::Index* e,
                     JointSystem* s) {
  const Vec3 model_reading = modelReading(t, r);
  const Vec3 res = r.reading - model_reading;
  std::array<Vec3, model::kTriadSize> g;
  for (int j = 0; j < model::kTriadSize; ++j) g[static_cast<std::size_t>(j)] = entryGain(t, r, j);
  std::vector<Vec3> tab;
  for (const Vec3& di : r.dinput) tab.push_back(modelReading(t, r, r.input + di) - model_reading);
  double ss = 0.0;
  for (int a = 0; a < 3; ++a, ++*e) {
    const double w = 1.0 / std::max(r.se[a], floor);
    s->b(*e) = w * res[a];
    ss += s->b(*e) * s->b(*e);
    int col = first;
    for (int j = 0; j < model::kTriadSize; ++j) {
      const model::ThermalCoefficient& c = t[static_cast<std::size_t>(j)];
      const double wg = w * g[static_cast<std::size_t>(j)][a];
      double x = 1.0;
      for (int k = 0; k <= c.order; ++k, x *= r.dT / ctx.scale) s->J(*e, col++) = wg * x;
      if (c.hysteresis) s->J(*e, col++) = wg * r.rate / ctx.rate_scale;
    }
    for (std::size_t p = 0; p < tab.size(); ++p) {
      s->J(*e, coef_terms + static_cast<Eigen::Index>(p)) = w * tab[p][a];
    }
  }
  s->chi2[static_cast<std::size_t>(tri)] += ss;
  s->rows.emplace_back(std::sqrt(ss / 3.0), r.where + (tri == 0 ? " accel" : " gyro"));
}

JointSystem jointSystem(const JointData& d, const model::ThermalCoefficients& c,
                        const FitContext& ctx, const ThermalJointFitOptions& o) {
  JointSystem s;
  std::array<int, 2> first{};
  for (const int tri : {0, 1}) {
    first[static_cast<std::size_t>(tri)] = s.coef_terms;
    for (const auto& k : tri == 0 ? c.accel : c.gyro) s.coef_terms += termCount(k);
    s.params[static_cast<std::size_t>(tri)] = s.coef_terms - first[static_cast<std::size_t>(tri)];
  }
  const Eigen::Index m = static_cast<Eigen::Index>(3 * (d.accel.size() + d.gyro.size()));
  s.J.setZero(m, s.coef_terms + static_cast<Eigen::Index>(d.params.size()));
  s.b.setZero(m);
  Eigen::Index e = 0;
  for (const int tri : {0, 1}) {
    const auto& rows = tri == 0 ? d.accel : d.gyro;
    s.equations[static_cast<std::size_t>(tri)] = static_cast<int>(3 * rows.size());
    for (const JointRow& r : rows) {
      addRowEquations(r, tri == 0 ? c.accel : c.gyro, tri, first[static_cast<std::size_t>(tri)],
                      s.coef_terms, ctx, floorOf(o, tri == 0), &e, &s);
    }
  }
  return s;
}

// Physical unit of term i of the system (undoing the column scaling of the powers of dT/scale
// and of rate/rate_scale).
Eigen::VectorXd termUnits(const model::ThermalCoefficients& c, const FitContext& ctx,
                          Eigen::Index n) {
  Eigen::VectorXd u = Eigen::VectorXd::Ones(n);
  Eigen::Index i = 0;
  for (const auto* t : {&c.accel, &c.gyro}) {
    for (const auto& k : *t) {
      for (int p = 0; p <= k.order; ++p) u(i++) = std::pow(ctx.scale, -p);
      if (k.hysteresis) u(i++) = 1.0 / ctx.rate_scale;
    }
  }
  return u;
}

// Gauss-Newton step of everything at c (only the table errors' part is applied: the
// coefficients are refitted with their orders by BIC), sigmas scaled by the Birge factors.
JointStep jointStep(const JointData& d, const model::ThermalCoefficients& c, const FitContext& ctx,
                    const ThermalJointFitOptions& o) {
  JointSystem s = jointSystem(d, c, ctx, o);
  const Eigen::Index P = s.J.cols(), nt = P - s.coef_terms;
  Eigen::VectorXd D(P);
  for (Eigen::Index k = 0; k < P; ++k) {
    D(k) = s.J.col(k).norm();
    if (!(D(k) > 0.0)) D(k) = 1.0;
    s.J.col(k) /= D(k);
  }
  const Eigen::MatrixXd N = s.J.transpose() * s.J;
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(N);
  const Eigen::VectorXd x = cod.solve(s.J.transpose() * s.b).cwiseQuotient(D);
  const Eigen::MatrixXd Ninv = cod.pseudoInverse();
  const Eigen::VectorXd var = Ninv.diagonal().cwiseQuotient(D.cwiseAbs2());
  JointStep st;
  for (const std::size_t tri : {0u, 1u}) {
    st.nrms[tri] = std::sqrt(s.chi2[tri] / std::max(1, s.equations[tri] - s.params[tri]));
  }
  const double dof = std::max<double>(1.0, static_cast<double>(s.b.size() - P));
  const double birge = std::max(1.0, std::sqrt((s.chi2[0] + s.chi2[1]) / dof));
  st.dtable = x.tail(nt);
  st.sigma_table = birge * var.tail(nt).cwiseSqrt();
  st.coef_sigma = var.head(s.coef_terms).cwiseSqrt().cwiseProduct(termUnits(c, ctx, s.coef_terms));
  Eigen::Index i = 0;
  for (const std::size_t tri : {0u, 1u}) {
    const double scale = std::max(1.0, st.nrms[tri]);
    for (Eigen::Index k = 0; k < s.params[tri]; ++k) st.coef_sigma(i++) *= scale;
  }
  st.rows = std::move(s.rows);
  return st;
}

// Every coefficient term's sigma: the larger of its own (others held) and the joint one.
void widenSigmas(const Eigen::VectorXd& joint, model::ThermalCoefficients* c) {
  Eigen::Index i = 0;
  for (auto* t : {&c->accel, &c->gyro}) {
    for (auto& k : *t) {
      for (int p = 0; p <= k.order; ++p) {
        double& s = k.sigma_poly[static_cast<std::size_t>(p)];
        s = std::max(s, joint(i++));
      }
      if (k.hysteresis) k.sigma_dTdt = std::max(k.sigma_dTdt, joint(i++));
    }
  }
}

// ---- The gate -----------------------------------------------------------------------------

// The coefficients at t_ref (c0 and its sigma) as a report judgeCoefficients reads.
CoefficientReport reportAtReference(const model::ThermalCoefficients& c) {
  CoefficientReport rep;
  for (const bool accel : {true, false}) {
    const model::ThermalTriad& t = accel ? c.accel : c.gyro;
    std::array<double, model::kTriadSize> block{};
    for (int i = 0; i < model::kTriadSize; ++i) {
      const std::size_t u = static_cast<std::size_t>(i);
      block[u] = t[u].poly[0];
      rep.setSigma(thermalCoefficientName(accel ? "accel" : "gyro", i), t[u].sigma_poly[0]);
    }
    (accel ? rep.values.sensors.accel : rep.values.sensors.gyro) =
        TriadModel::fromBlock(block.data());
  }
  return rep;
}

// What the table errors were in the fit, for the findings.
std::string tableTaken(const JointData& d, const ThermalJointFitOptions& o) {
  if (!o.estimate_table) return "the table errors held at the given values (--table-errors)";
  if (d.params.empty()) return "no table error observable (all held)";
  std::string s;
  for (const std::string& p : d.params) s += (s.empty() ? "" : ", ") + p.substr(6);
  return "table errors estimated: " + s;
}

FitStatus judgeJoint(const JointData& d, const JointStep& st, const model::ThermalCoefficients& c,
                     bool converged, const ThermalJointFitOptions& o) {
  std::vector<std::string> reasons;
  bool misfit = false;
  for (const std::size_t tri : {0u, 1u}) {
    if (st.nrms[tri] <= o.direct.quality.max_normalised_rms) continue;
    misfit = true;
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%s rows: normalised residual RMS %.3g (limit %.3g)",
                  tri == 0 ? "accel" : "gyro", st.nrms[tri], o.direct.quality.max_normalised_rms);
    reasons.push_back(std::string(buf) + " with " + tableTaken(d, o) +
                      ": the thermal model does not fit the data (table errors held at wrong "
                      "values, or an effect the model lacks)");
  }
  judgeCoefficients(reportAtReference(c), o.direct.quality, &reasons);
  for (std::size_t p = 0; p < d.params.size(); ++p) {
    const double s = st.sigma_table(static_cast<Eigen::Index>(p));
    if (!(s <= o.max_table_sigma_rad)) {
      reasons.push_back(d.params[p] + " is not determined by the data (sigma " + arcsec(s) + ")");
    }
  }
  if (!converged) {
    reasons.push_back("the table errors did not converge in " +
                      std::to_string(o.max_table_iterations) + " iterations");
  }
  std::vector<std::pair<double, std::string>> worst = st.rows;
  std::sort(worst.begin(), worst.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> largest;
  for (std::size_t k = 0; k < worst.size() && k < 3; ++k) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), ": %.1f sigma", worst[k].first);
    largest.push_back(worst[k].second + buf);
  }
  FitStatus s = fitStatusFrom(std::move(reasons), std::move(largest));
  s.misfit = misfit;
  return s;
}

// The table report: values, sigmas of the estimated errors, every other one unobservable.
CoefficientReport tableReport(const BenchTruth& table, const JointData& d, const JointStep& st) {
  CoefficientReport rep;
  rep.values.table = table.table;
  rep.values.table_kind = table.table_kind;
  for (const std::string& n : tableFlatNames(table.table_kind)) {
    const auto it = std::find(d.params.begin(), d.params.end(), n);
    if (it == d.params.end()) {
      rep.setUnobservable(n);
    } else {
      rep.setSigma(n, st.sigma_table(it - d.params.begin()));
    }
  }
  return rep;
}

// ---- The fit ------------------------------------------------------------------------------

// Rows of every run, the table errors to estimate chosen; false + why.
bool prepare(const std::vector<ThermalRun>& runs, const ThermalJointFitOptions& o,
             const BenchTruth& table, double t_scale, JointData* d, std::vector<std::string>* notes,
             std::string* why) {
  for (const ThermalRun& run : runs) {
    if (!jointRows(run, o, table, d, notes, why)) return false;
  }
  if (d->params.empty()) return true;
  Eigen::MatrixXd C, T;
  observabilityDesign(*d, o, t_scale, &C, &T);
  keepParams(observableTable(C, T, d->params, table, o, notes), d);
  return true;
}

// The context of the coefficient fits (scales, hysteresis candidate) from the rows.
FitContext fitContext(const JointData& d, const ThermalJointFitOptions& o, bool* hysteresis) {
  FitContext ctx{&o.fit};
  bool heating = false, cooling = false;
  ctx.rate_scale = o.fit.min_hysteresis_rate;
  for (const double T : d.temps) ctx.scale = std::max(ctx.scale, std::abs(T - o.fit.t_ref_c));
  for (const auto* rows : {&d.accel, &d.gyro}) {
    for (const JointRow& row : *rows) {
      ctx.rate_scale = std::max(ctx.rate_scale, std::abs(row.rate));
      heating = heating || row.rate > o.fit.min_hysteresis_rate;
      cooling = cooling || row.rate < -o.fit.min_hysteresis_rate;
    }
  }
  *hysteresis = ctx.hysteresis = heating && cooling;
  return ctx;
}

// Table kind of the runs (one table); false + why when they differ.
bool tableKindOf(const std::vector<ThermalRun>& runs, TableKind* kind, std::string* why) {
  if (runs.empty()) {
    *why = "no recordings";
    return false;
  }
  *kind = runs.front().input.geometry.kind;
  for (const ThermalRun& r : runs) {
    if (r.input.geometry.kind != *kind) {
      *why = r.source + ": another table kind than " + runs.front().source +
             ": the table errors are one table's";
      return false;
    }
  }
  return true;
}

}  // namespace

bool ThermalJointFitOptions::IsValid(std::string* why) const {
  if (!fit.IsValid(why) || !direct.IsValid(why) || !rate.IsValid(why)) return false;
  if (max_sweeps < 1 || !(tolerance > 0.0)) {
    if (why) *why = "max_sweeps must be >= 1 and tolerance > 0";
    return false;
  }
  if (!(min_table_information > 0.0 && min_table_information < 1.0) ||
      !(max_table_sigma_rad > 0.0) || max_table_iterations < 1 || !(table_tolerance > 0.0)) {
    if (why) {
      *why =
          "min_table_information must be in (0, 1), max_table_sigma_rad and table_tolerance > 0, "
          "max_table_iterations >= 1";
    }
    return false;
  }
  return true;
}

namespace {

// Outer iterations: coefficients by Gauss-Seidel at the current table, then the joint step of
// the table errors; false + why (a coefficient not determined, a run failing).
bool iterateTable(const std::vector<ThermalRun>& runs, const ThermalJointFitOptions& o,
                  const FitContext& ctx, JointData* d, BenchTruth* table, ThermalRunsFitResult* r,
                  JointStep* st, bool* converged, std::string* why) {
  model::ThermalCoefficients& c = r->fit.coefficients;
  int sweeps_a = 0, sweeps_g = 0;
  *converged = d->params.empty();
  for (int it = 0; it < o.max_table_iterations; ++it) {
    for (std::size_t k = 0; k < runs.size() && it > 0; ++k) {
      if (!refreshInputs(runs[k], k, o, *table, false, d, why)) return false;
    }
    r->fit.fits.clear();
    if (!fitTriadJoint(d->accel, ctx, o, "accel", &c.accel, &r->fit.fits, &sweeps_a, it > 0, why) ||
        !fitTriadJoint(d->gyro, ctx, o, "gyro", &c.gyro, &r->fit.fits, &sweeps_g, it > 0, why)) {
      return false;
    }
    r->passes = std::max(r->passes, std::max(sweeps_a, sweeps_g));
    r->table_iterations = it + 1;
    *st = jointStep(*d, c, ctx, o);
    if (d->params.empty()) break;
    *converged = true;
    for (Eigen::Index p = 0; p < st->dtable.size(); ++p) {
      *converged = *converged && std::abs(st->dtable(p)) <= o.table_tolerance * st->sigma_table(p);
    }
    if (*converged || it + 1 == o.max_table_iterations) break;
    for (std::size_t p = 0; p < d->params.size(); ++p) {
      const double v = flatValue(*table, d->params[p]).value_or(0.0);
      setFlatValue(table, d->params[p], v + st->dtable(static_cast<Eigen::Index>(p)), why);
    }
  }
  return true;
}

}  // namespace

ThermalRunsFitResult fitThermalJoint(const std::vector<ThermalRun>& runs,
                                     const ThermalJointFitOptions& options) {
  ThermalRunsFitResult r;
  std::string why;
  BenchTruth table;
  if (!options.IsValid(&why) || !tableKindOf(runs, &table.table_kind, &why)) {
    r.status = FitStatus::Failed(std::move(why));
    return r;
  }
  table.table = options.direct.known_table_errors;
  JointData d;
  if (options.estimate_table) d.params = tableFlatNames(table.table_kind);
  double t_scale = 1.0;
  for (const ThermalRun& run : runs) {
    for (const nav::ImuSample& s : run.input.imu) {
      if (std::isfinite(s.temp_c))
        t_scale = std::max(t_scale, std::abs(s.temp_c - options.fit.t_ref_c));
    }
  }
  if (!prepare(runs, options, table, t_scale, &d, &r.notes, &why)) {
    r.status = FitStatus::Failed(std::move(why));
    return r;
  }
  ThermalFitResult& fit = r.fit;
  fit.distinct_temperatures = distinctTemperatures(d.temps, options.fit.same_temperature_c);
  if (fit.distinct_temperatures < 2) {
    fit.status = FitStatus::Failed("a single temperature point (all rows within " +
                                   std::to_string(options.fit.same_temperature_c) +
                                   " degC): a thermal model needs at least two temperatures");
    r.status = fit.status;
    return r;
  }
  const FitContext ctx = fitContext(d, options, &fit.hysteresis_candidate);
  model::ThermalCoefficients& c = fit.coefficients;
  c.t_ref_c = options.fit.t_ref_c;
  c.t_min_c = *std::min_element(d.temps.begin(), d.temps.end());
  c.t_max_c = *std::max_element(d.temps.begin(), d.temps.end());
  JointStep st;
  bool converged = false;
  if (!iterateTable(runs, options, ctx, &d, &table, &r, &st, &converged, &why)) {
    // A coefficient the rows do not determine: the fit's failure, not a run's.
    fit.status = FitStatus::Failed(std::move(why));
    r.status = fit.status;
    return r;
  }
  widenSigmas(st.coef_sigma, &c);
  r.accel_normalised_rms = st.nrms[0];
  r.gyro_normalised_rms = st.nrms[1];
  r.table = tableReport(table, d, st);
  if (!options.estimate_table) r.notes.push_back("table errors held at the given values");
  fit.status = FitStatus();
  r.status = judgeJoint(d, st, c, converged, options);
  return r;
}

}  // namespace imubench::calib
