#include "calib/observability.h"

#include <ceres/jet.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "calib/bench_truth.h"
#include "calib/model/bench_physics.h"
#include "calib/model/sensor_equation.h"
#include "calib/option_check.h"
#include "calib/simulator.h"
#include "calib/table_model.h"

namespace imubench::calib {

bool InformationOptions::IsValid(std::string* why) const {
  if (!(rel_tol > 0.0 && rel_tol < 1.0)) {
    if (why) *why = "rel_tol must be in (0, 1)";
    return false;
  }
  if (!(show_component >= 0.0 && show_component < 1.0)) {
    if (why) *why = "show_component must be in [0, 1)";
    return false;
  }
  return true;
}

std::string describeDirection(const Eigen::VectorXd& v, const std::vector<std::string>& names,
                              double show_component) {
  std::vector<int> order;
  for (int k = 0; k < v.size(); ++k)
    if (std::abs(v(k)) >= show_component) order.push_back(k);
  // Largest first; near-ties keep the parameter order so descriptions are reproducible.
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return std::abs(v(a)) > std::abs(v(b)) + 1e-9; });
  // Sign convention: the largest component positive.
  const double sign = !order.empty() && v(order.front()) < 0.0 ? -1.0 : 1.0;
  std::ostringstream names_out, coef_out;
  coef_out << std::fixed << std::setprecision(2);
  for (std::size_t i = 0; i < order.size(); ++i) {
    names_out << (i ? " + " : "") << names[static_cast<std::size_t>(order[i])];
    coef_out << (i ? ", " : "") << sign * v(order[i]);
  }
  return names_out.str() + " (" + coef_out.str() + ")";
}

InformationAnalysis analyseInformation(const Eigen::MatrixXd& J,
                                       const std::vector<std::string>& names,
                                       const InformationOptions& options) {
  InformationAnalysis a;
  a.names = names;
  std::string why;
  if (!options.IsValid(&why)) {
    a.status = Status::Error(why);
    return a;
  }
  if (static_cast<std::size_t>(J.cols()) != names.size() || J.cols() == 0) {
    a.status = Status::Error("Jacobian has " + std::to_string(J.cols()) + " columns for " +
                             std::to_string(names.size()) + " parameter names");
    return a;
  }
  const Eigen::Index p = J.cols();
  a.column_scale = J.colwise().norm().transpose();
  Eigen::MatrixXd Jn = J;
  // A column many orders below the largest is rounding noise (e.g. cos(90 deg) ~ 6e-17):
  // treat it as never seen rather than normalising the noise up to unit size.
  const double col_floor = 1e-12 * a.column_scale.maxCoeff();
  for (Eigen::Index k = 0; k < p; ++k) {
    if (a.column_scale(k) > col_floor) {
      Jn.col(k) /= a.column_scale(k);
    } else {
      Jn.col(k).setZero();
    }
  }
  a.fisher = Jn.transpose() * Jn;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a.fisher);
  a.eigenvalues = es.eigenvalues();
  a.eigenvectors = es.eigenvectors();
  const double lmax = std::max(a.eigenvalues.maxCoeff(), 0.0);
  const double thr = options.rel_tol * lmax;
  a.observable.assign(static_cast<std::size_t>(p), true);
  double lmin_ok = lmax;
  for (Eigen::Index k = 0; k < p; ++k) {
    const double l = a.eigenvalues(k);
    if (l > thr) {
      lmin_ok = std::min(lmin_ok, l);
      continue;
    }
    NullDirection d;
    d.eigenvalue = l;
    d.vector = a.eigenvectors.col(k);
    d.description = describeDirection(d.vector, names, options.show_component);
    for (Eigen::Index i = 0; i < p; ++i)
      if (std::abs(d.vector(i)) >= options.show_component)
        a.observable[static_cast<std::size_t>(i)] = false;
    a.null_directions.push_back(std::move(d));
  }
  a.condition = lmin_ok > 0.0 ? lmax / lmin_ok : std::numeric_limits<double>::infinity();
  return a;
}

}  // namespace imubench::calib

// ---- Plan observability ----------------------------------------------------------------

namespace imubench::calib {

bool PlanObservabilityOptions::IsValid(std::string* why) const {
  if (!(accel_sigma > 0.0) || !(angle_sigma > 0.0)) return invalidOption(why, "sigmas must be > 0");
  return information.IsValid(why);
}

namespace {

using model::Mat3T;
using model::Vec3T;

// Parameters the Jets carry (two-axis 33, three-axis 36 with the site errors).
constexpr int kMaxObservabilityParams = 40;

BenchTruth nominalTruth(TableKind kind) {
  BenchTruth t;
  t.table_kind = kind;
  t.extra.enable(EffectId::kGravityError);
  t.extra.enable(EffectId::kLatitudeError);
  return t;
}

struct PlanSegments {
  std::vector<TableAngles> statics;
  struct Run {
    TableAngles start, end;
    int axis = 0;
    double angle = 0.0;
    double duration = 0.0;
  };
  std::vector<Run> runs;
};

PlanSegments planSegments(const Motion& m) {
  PlanSegments p;
  for (const Segment& s : m.segments) {
    if (!s.recording) continue;
    if (s.kind == SegmentKind::kStatic) {
      p.statics.push_back(tableStateAt(m, 0.5 * (s.t0 + s.t1)).angles());
    } else if (s.kind == SegmentKind::kRotate && s.axis >= 0) {
      PlanSegments::Run r;
      r.start = tableStateAt(m, s.t0).angles();
      r.end = tableStateAt(m, s.t1).angles();
      r.axis = s.axis;
      // Net turn from the motion itself (consistent with start/end attitudes).
      const double a0 = r.axis == 0                                        ? r.start.outer
                        : (m.kind == TableKind::kThreeAxis && r.axis == 1) ? r.start.middle
                                                                           : r.start.inner;
      const double a1 = r.axis == 0                                        ? r.end.outer
                        : (m.kind == TableKind::kThreeAxis && r.axis == 1) ? r.end.middle
                                                                           : r.end.inner;
      r.angle = a1 - a0;
      r.duration = s.t1 - s.t0;
      p.runs.push_back(r);
    }
  }
  return p;
}

// Where each model quantity sits in the flat parameter vector of observabilityParameterNames
// (-1: not a parameter of this table kind, held at zero).
struct ParamIndex {
  int accel = -1;  // start of the accel triad block (model order: scale, bias, misalignment)
  int gyro = -1;   // start of the gyro triad block
  std::array<int, model::kTableAxesSize> axes{};
  std::array<int, model::kTableDeviceSize> device{};
  int dg = -1;    // gravity_error.dg_mps2
  int dlat = -1;  // latitude_error.dlat_rad
};

ParamIndex paramIndex(const std::vector<std::string>& names) {
  auto at = [&names](const std::string& n) {
    const auto it = std::find(names.begin(), names.end(), n);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  ParamIndex ix;
  // The flat names list each triad in the model's block order, so a block is one offset.
  ix.accel = at("accel.scale.x");
  ix.gyro = at("gyro.scale.x");
  ix.axes[model::kTiltX] = at("table.base_tilt.x");
  ix.axes[model::kTiltY] = at("table.base_tilt.y");
  ix.axes[model::kNonorthInnerY] = at("table.nonorthogonality.inner_y");
  ix.axes[model::kNonorthMiddleX] = at("table.nonorthogonality.middle_x");
  ix.axes[model::kNonorthMiddleY] = at("table.nonorthogonality.middle_y");
  ix.device[model::kMountX] = at("table.mounting.x");
  ix.device[model::kMountY] = at("table.mounting.y");
  ix.device[model::kZeroOuter] = at("table.encoder_zero.outer");
  ix.device[model::kZeroMiddle] = at("table.encoder_zero.middle");
  ix.device[model::kZeroInner] = at("table.encoder_zero.inner");
  ix.dg = at("extra.gravity_error.dg_mps2");
  ix.dlat = at("extra.latitude_error.dlat_rad");
  return ix;
}

// Unit rate of one table axis (the rotation axis in B through the chain's kinematics).
template <typename T>
Vec3T<T> axisInBody(const model::ChainFactors<T>& f, const model::ChainErrors<T>& e,
                    const TableAngles& a, TableKind kind, int axis) {
  model::JointState<T> o{T(a.outer) + e.zero_outer, T(0.0), T(0.0)};
  model::JointState<T> m{T(a.middle) + e.zero_middle, T(0.0), T(0.0)};
  model::JointState<T> i{T(a.inner) + e.zero_inner, T(0.0), T(0.0)};
  if (axis == 0)
    o.rate = T(1.0);
  else if (kind == TableKind::kThreeAxis && axis == 1)
    m.rate = T(1.0);
  else
    i.rate = T(1.0);
  return model::chainKinematics(f, o, m, i).w_LB_B;
}

// Measurements the method sees, whitened, for the world x (flat parameters, zero = nominal):
// the model's sensor equation, table chain and bench physics (calib/model/), templated so the
// Jacobian comes from automatic differentiation of the very functions the calibrators use.
template <typename T>
std::vector<T> measure(const PlanSegments& segs, TableKind kind, const T* x, const ParamIndex& ix,
                       CalibrationMethod method, const PlanObservabilityOptions& o) {
  using std::cos;
  using std::sin;
  auto param = [x](int i) { return i >= 0 ? x[i] : T(0.0); };
  // True site: assumed + latitude_error; gravity = normal gravity there + gravity_error. The
  // normal-gravity change with latitude enters through its derivative (a double function).
  const double lat0 = o.site.latitude_rad;
  const double dgdlat = o.site.gravity_mps2 ? 0.0
                                            : (nav::normalGravity(lat0 + 1e-6, o.site.height_m) -
                                               nav::normalGravity(lat0 - 1e-6, o.site.height_m)) /
                                                  2e-6;
  const T lat = T(lat0) + param(ix.dlat);
  const T g = T(nav::siteGravity(o.site)) + T(dgdlat) * param(ix.dlat) + param(ix.dg);
  const Vec3T<T> w_ie_L(T(0.0), T(nav::kEarthRate) * cos(lat), T(nav::kEarthRate) * sin(lat));
  std::array<T, model::kTableAxesSize> axes;
  std::array<T, model::kTableDeviceSize> device;
  for (int k = 0; k < model::kTableAxesSize; ++k) axes[k] = param(ix.axes[k]);
  for (int k = 0; k < model::kTableDeviceSize; ++k) device[k] = param(ix.device[k]);
  const model::ChainErrors<T> e = model::chainErrors(kind, axes.data(), device.data());
  const model::ChainFactors<T> table = model::chainFactors(kind, o.outer_axis_heading_rad, e);
  const model::ChainFactors<T> nominal =
      model::chainFactors(kind, o.outer_axis_heading_rad, model::ChainErrors<T>{});
  auto C_LB = [&](const model::ChainFactors<T>& f, const model::ChainErrors<T>& err,
                  const TableAngles& a) {
    return model::chainAttitude(f, T(a.outer) + err.zero_outer, T(a.middle) + err.zero_middle,
                                T(a.inner) + err.zero_inner);
  };
  const model::ChainErrors<T> none;
  // What the IMU senses at rest at the given angles (the model's bench physics).
  auto atRest = [&](const TableAngles& a) {
    model::ChainKinematics<T> k;
    k.C_LB = C_LB(table, e, a);
    return model::benchPhysics(k, g, w_ie_L);
  };
  const T* accel = x + ix.accel;
  const T* gyro = x + ix.gyro;
  std::vector<T> out;
  auto push = [&out](const Vec3T<T>& v, double sigma) {
    for (int k = 0; k < 3; ++k) out.push_back(v[k] / T(sigma));
  };
  if (method == CalibrationMethod::kDirect) {
    for (const TableAngles& a : segs.statics) {
      const model::Physics<T> p = atRest(a);
      push(model::reading(accel, p.f_B), o.accel_sigma);
      // Static gyro mean over a nominal 100 s hold, as an angle.
      push(model::reading(gyro, p.w_IB_B) * T(100.0), o.angle_sigma);
    }
    for (const PlanSegments::Run& r : segs.runs) {
      const Vec3T<T> axis_B = axisInBody(table, e, r.start, kind, r.axis);
      const Vec3T<T> earth = atRest(r.start).w_IB_B * T(r.duration);
      const Vec3T<T> rate = (axis_B * T(r.angle) + earth) / T(r.duration);
      push(model::reading(gyro, rate) * T(r.duration), o.angle_sigma);
    }
    return out;
  }
  // Navigation-based, as calib/indirect/indirect_calibration.h measures: at every hold the solution
  // started from the nominal table setting resolves the specific force and the Earth rate in
  // L (horizontal apparent acceleration, vertical against gravity, rate against w_ie)...
  for (const TableAngles& a : segs.statics) {
    const model::Physics<T> p = atRest(a);
    const Mat3T<T> C_LB_nav = C_LB(nominal, none, a);
    push(C_LB_nav * model::reading(accel, p.f_B), o.accel_sigma);
    push(C_LB_nav * model::reading(gyro, p.w_IB_B) * T(100.0), o.angle_sigma);
  }
  // ... and through each run it turns with the measured gyro increments and compares the
  // apparent acceleration in L after and before (horizontal components: the seed's residual).
  for (const PlanSegments::Run& r : segs.runs) {
    const Vec3T<T> a0 = model::reading(accel, atRest(r.start).f_B);
    const Vec3T<T> a1 = model::reading(accel, atRest(r.end).f_B);
    const Vec3T<T> axis_B = axisInBody(table, e, r.start, kind, r.axis);
    const Vec3T<T> theta =
        model::reading(gyro, Vec3T<T>(axis_B * T(r.angle / r.duration))) * T(r.duration);
    const Vec3T<T> d = C_LB(nominal, none, r.start) * (model::smallRotation(theta) * a1 - a0);
    out.push_back(d.x() / T(o.accel_sigma));
    out.push_back(d.y() / T(o.accel_sigma));
  }
  return out;
}

// Jacobian of measure() at the nominal world (all errors zero, scales one) by automatic
// differentiation (ceres::Jet), columns in `names` order.
Eigen::MatrixXd measurementJacobian(const PlanSegments& segs, TableKind kind,
                                    const std::vector<std::string>& names,
                                    const std::vector<double>& x0, CalibrationMethod method,
                                    const PlanObservabilityOptions& o) {
  using Jet = ceres::Jet<double, kMaxObservabilityParams>;
  const ParamIndex ix = paramIndex(names);
  std::vector<Jet> x(names.size());
  for (std::size_t k = 0; k < names.size(); ++k) x[k] = Jet(x0[k], static_cast<int>(k));
  const std::vector<Jet> y = measure(segs, kind, x.data(), ix, method, o);
  Eigen::MatrixXd J(static_cast<Eigen::Index>(y.size()), static_cast<Eigen::Index>(names.size()));
  for (std::size_t r = 0; r < y.size(); ++r) {
    J.row(static_cast<Eigen::Index>(r)) =
        y[r].v.head(static_cast<Eigen::Index>(names.size())).transpose();
  }
  return J;
}

std::string methodName(CalibrationMethod m) {
  return m == CalibrationMethod::kDirect ? "direct" : "navigation-based (indirect)";
}

}  // namespace

std::vector<std::string> observabilityParameterNames(TableKind kind) {
  return flatNames(nominalTruth(kind));
}

PlanObservability analysePlanObservability(const Motion& motion, CalibrationMethod method,
                                           const PlanObservabilityOptions& o) {
  PlanObservability res;
  std::string why;
  if (!o.IsValid(&why)) {
    res.analysis.status = Status::Error(why);
    return res;
  }
  const PlanSegments segs = planSegments(motion);
  if (segs.statics.empty() && segs.runs.empty()) {
    res.analysis.status = Status::Error("the plan has no static or rotate segments");
    return res;
  }
  const BenchTruth base = nominalTruth(motion.kind);
  const std::vector<std::string> names = flatNames(base);
  if (names.size() > static_cast<std::size_t>(kMaxObservabilityParams)) {
    res.analysis.status = Status::Error("more parameters than the automatic differentiation holds");
    return res;
  }
  const Eigen::MatrixXd J =
      measurementJacobian(segs, motion.kind, names, flatValues(base), method, o);
  res.analysis = analyseInformation(J, names, o.information);
  if (!res.analysis.status.ok) return res;
  // The method's own parameter set (see PlanObservability::model_analysis).
  {
    std::vector<std::string> model_names;
    std::vector<Eigen::Index> cols;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const std::string& n = names[k];
      const bool sensor = n.rfind("accel.", 0) == 0 || n.rfind("gyro.", 0) == 0;
      const bool table_param =
          n.rfind("table.base_tilt", 0) == 0 || n.rfind("table.nonorthogonality", 0) == 0;
      if (sensor || (method == CalibrationMethod::kIndirect && table_param)) {
        model_names.push_back(n);
        cols.push_back(static_cast<Eigen::Index>(k));
      }
    }
    Eigen::MatrixXd Jm(J.rows(), static_cast<Eigen::Index>(cols.size()));
    for (std::size_t k = 0; k < cols.size(); ++k) {
      Jm.col(static_cast<Eigen::Index>(k)) = J.col(cols[k]);
    }
    res.model_analysis = analyseInformation(Jm, model_names, o.information);
  }
  const InformationAnalysis& a = res.analysis;
  auto observable = [&](const std::string& prefix) {
    bool all = true;
    for (std::size_t k = 0; k < names.size(); ++k)
      if (names[k].rfind(prefix, 0) == 0) all = all && a.observable[k];
    return all;
  };
  const std::string m = methodName(method);
  const struct {
    const char* prefix;
    const char* what;
  } groups[] = {{"table.mounting", "mounting angles (beta', gamma')"},
                {"table.base_tilt", "base tilt (beta_oc, gamma_oc)"},
                {"table.nonorthogonality", "axis non-orthogonality"},
                {"table.encoder_zero", "encoder zeros"},
                {"accel.misalignment", "accelerometer misalignments"},
                {"gyro.misalignment", "gyro misalignments"},
                {"accel.bias", "accelerometer biases"},
                {"gyro.scale", "gyro scale factors"}};
  for (const auto& gr : groups)
    res.statements.push_back(
        std::string(gr.what) +
        (observable(gr.prefix) ? " can be estimated by " : " cannot be estimated by ") + m +
        " calibration with this plan");
  {
    const InformationAnalysis& ma = res.model_analysis;
    std::string blind;
    for (std::size_t k = 0; k < ma.names.size(); ++k) {
      if (ma.observable[k]) continue;
      blind += (blind.empty() ? "" : ", ") + ma.names[k];
    }
    const std::string set = method == CalibrationMethod::kIndirect
                                ? "sensor coefficients, base tilt, nonorthogonality; mounting "
                                  "and encoder zeros absorbed"
                                : "sensor coefficients; the table taken as nominal";
    res.statements.push_back("in the method's own parameter set (" + set + "): " +
                             (blind.empty()
                                  ? std::string("every parameter can be estimated with this plan")
                                  : "cannot be estimated with this plan (fixed and flagged by the "
                                    "calibrator): " +
                                        blind));
  }
  for (const NullDirection& d : a.null_directions) {
    const bool has_g = d.description.find("gravity_error") != std::string::npos;
    const bool has_scale = d.description.find("accel.scale") != std::string::npos;
    if (has_g && has_scale)
      res.statements.push_back(
          "gravity error is indistinguishable from a common accelerometer scale factor: " +
          d.description);
    else
      res.statements.push_back("not separable: " + d.description);
  }
  return res;
}

}  // namespace imubench::calib
