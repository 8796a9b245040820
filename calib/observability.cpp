#include "calib/observability.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "calib/bench_truth.h"
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
    a.ok = false;
    a.reason = why;
    return a;
  }
  if (static_cast<std::size_t>(J.cols()) != names.size() || J.cols() == 0) {
    a.ok = false;
    a.reason = "Jacobian has " + std::to_string(J.cols()) + " columns for " +
               std::to_string(names.size()) + " parameter names";
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
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(step > 0.0 && step < 1e-2)) return fail("step must be in (0, 1e-2)");
  if (!(accel_sigma > 0.0) || !(angle_sigma > 0.0)) return fail("sigmas must be > 0");
  return information.IsValid(why);
}

namespace {

BenchTruth nominalTruth(TableKind kind) {
  BenchTruth t;
  t.table_kind = kind;
  t.extra.enable(EffectId::kGravityError);
  t.extra.enable(EffectId::kLatitudeError);
  return t;
}

Vec3 readingOf(const TriadModel& t, const Vec3& input) {
  return t.scale.cwiseProduct(t.M() * input - t.bias);
}

// Rotation vector -> rotation matrix.
Mat3 expRot(const Vec3& phi) {
  return quatFromRotationVector(phi).toRotationMatrix();
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

TableState unitRate(const TableAngles& a, TableKind kind, int axis) {
  TableState st;
  st.outer.angle = a.outer;
  st.middle.angle = a.middle;
  st.inner.angle = a.inner;
  if (axis == 0)
    st.outer.rate = 1.0;
  else if (kind == TableKind::kThreeAxis && axis == 1)
    st.middle.rate = 1.0;
  else
    st.inner.rate = 1.0;
  return st;
}

// Measurements the method sees, whitened, for a given true world.
Eigen::VectorXd measure(const PlanSegments& segs, TableKind kind, const BenchTruth& truth,
                        CalibrationMethod method, const PlanObservabilityOptions& o) {
  const nav::Site site = trueSite(o.site, truth.extra);
  const double g = nav::siteGravity(site);
  const Vec3 w_ie_L = nav::earthRateL(site.latitude_rad);
  const TableGeometry geo{kind, o.outer_axis_heading_rad};
  const TableModel table(geo, truth.table);
  const TableModel nominal(geo, TableErrors{});
  const SensorModel& s = truth.sensors;
  std::vector<double> out;
  auto push = [&out](const Vec3& v, double sigma) {
    for (int k = 0; k < 3; ++k) out.push_back(v[k] / sigma);
  };
  if (method == CalibrationMethod::kDirect) {
    for (const TableAngles& a : segs.statics) {
      const Mat3 C_BL = table.C_LB(a).transpose();
      push(readingOf(s.accel, C_BL * Vec3(0, 0, g)), o.accel_sigma);
      // Static gyro mean over a nominal 100 s hold, as an angle.
      push(readingOf(s.gyro, C_BL * w_ie_L) * 100.0, o.angle_sigma);
    }
    for (const PlanSegments::Run& r : segs.runs) {
      const Vec3 axis_B = table.kinematics(unitRate(r.start, kind, r.axis)).w_LB_B;
      const Vec3 earth = table.C_LB(r.start).transpose() * w_ie_L * r.duration;
      const Vec3 rate = (axis_B * r.angle + earth) / r.duration;
      push(readingOf(s.gyro, rate) * r.duration, o.angle_sigma);
    }
  } else {
    // Navigation-based, as calib/indirect_calibration.h measures: at every hold the solution
    // started from the nominal table setting resolves the specific force and the Earth rate in
    // L (horizontal apparent acceleration, vertical against gravity, rate against w_ie)...
    for (const TableAngles& a : segs.statics) {
      const Mat3 C_BL = table.C_LB(a).transpose();
      const Mat3 C_LB_nav = nominal.C_LB(a);
      push(C_LB_nav * readingOf(s.accel, C_BL * Vec3(0, 0, g)), o.accel_sigma);
      push(C_LB_nav * readingOf(s.gyro, C_BL * w_ie_L) * 100.0, o.angle_sigma);
    }
    // ... and through each run it turns with the measured gyro increments and compares the
    // apparent acceleration in L after and before (horizontal components: the seed's residual).
    for (const PlanSegments::Run& r : segs.runs) {
      const Mat3 C_BL0 = table.C_LB(r.start).transpose();
      const Mat3 C_BL1 = table.C_LB(r.end).transpose();
      const Vec3 a0 = readingOf(s.accel, C_BL0 * Vec3(0, 0, g));
      const Vec3 a1 = readingOf(s.accel, C_BL1 * Vec3(0, 0, g));
      const Vec3 axis_B = table.kinematics(unitRate(r.start, kind, r.axis)).w_LB_B;
      const Vec3 theta = readingOf(s.gyro, axis_B * r.angle / r.duration) * r.duration;
      const Mat3 C_LB_nav0 = nominal.C_LB(r.start);
      const Vec3 d = C_LB_nav0 * (expRot(theta) * a1 - a0);
      out.push_back(d.x() / o.accel_sigma);
      out.push_back(d.y() / o.accel_sigma);
    }
  }
  return Eigen::Map<Eigen::VectorXd>(out.data(), static_cast<Eigen::Index>(out.size()));
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
    res.analysis.ok = false;
    res.analysis.reason = why;
    return res;
  }
  const PlanSegments segs = planSegments(motion);
  if (segs.statics.empty() && segs.runs.empty()) {
    res.analysis.ok = false;
    res.analysis.reason = "the plan has no static or rotate segments";
    return res;
  }
  const BenchTruth base = nominalTruth(motion.kind);
  const std::vector<std::string> names = flatNames(base);
  const Eigen::VectorXd y0 = measure(segs, motion.kind, base, method, o);
  Eigen::MatrixXd J(y0.size(), static_cast<Eigen::Index>(names.size()));
  for (std::size_t k = 0; k < names.size(); ++k) {
    // Relative step for scale factors (about 1), absolute otherwise; gravity in m/s^2.
    BenchTruth plus = base, minus = base;
    const double x0 = flatValue(base, names[k]).value_or(0.0);
    const double h = names[k].find("gravity") != std::string::npos ? 1e-5 : o.step;
    setFlatValue(&plus, names[k], x0 + h, nullptr);
    setFlatValue(&minus, names[k], x0 - h, nullptr);
    J.col(static_cast<Eigen::Index>(k)) = (measure(segs, motion.kind, plus, method, o) -
                                           measure(segs, motion.kind, minus, method, o)) /
                                          (2.0 * h);
  }
  res.analysis = analyseInformation(J, names, o.information);
  if (!res.analysis.ok) return res;
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
