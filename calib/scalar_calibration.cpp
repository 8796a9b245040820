#include "calib/scalar_calibration.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calib/observability.h"
#include "nav/earth.h"

namespace imubench::calib {

bool ScalarCalibrationOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(gravity_mps2 > 9.7 && gravity_mps2 < 9.9))
    return fail("gravity_mps2 must be in (9.7, 9.9)");
  if (gyro_scale_guess && !(*gyro_scale_guess > 0.0)) return fail("gyro_scale_guess must be > 0");
  if (!(min_initial_static_s >= 0.0)) return fail("min_initial_static_s must be >= 0");
  if (!(same_pose_angle_deg > 0.0 && same_pose_angle_deg < 90.0)) {
    if (why) *why = "same_pose_angle_deg must be in (0, 90)";
    return false;
  }
  if (min_poses_diagonal_accel < 6 || min_poses_full_accel < 9)
    return fail("pose minimums below the number of unknowns (6 diagonal, 9 full)");
  if (!(span_trim_s >= 0.0)) return fail("span_trim_s must be >= 0");
  if (!(si_gravity_tolerance > 0.0 && si_gravity_tolerance < 1.0))
    return fail("si_gravity_tolerance must be in (0, 1)");
  if (!(max_static_scatter_g > 0.0)) return fail("max_static_scatter_g must be > 0");
  if (!(min_axis_span >= 0.0 && min_axis_span <= 2.0))
    return fail("min_axis_span must be in [0, 2]");
  if (!(max_gyro_rms_rad > 0.0)) return fail("max_gyro_rms_rad must be > 0");
  return detection.IsValid(why) && checks.IsValid(why);
}

namespace {

// Accelerometer parameters: scale[3], bias[3], upper misalignments [xy, xz, yz].
struct AccelNormCost {
  Vec3 a;
  double g;
  template <typename T>
  bool operator()(const T* s, const T* b, const T* m, T* r) const {
    const T ux = T(a.x()) / s[0] + b[0];
    const T uy = T(a.y()) / s[1] + b[1];
    const T uz = T(a.z()) / s[2] + b[2];
    // M = [[1, m_xy, -m_xz], [0, 1, m_yz], [0, 0, 1]]: back substitution.
    const T fz = uz;
    const T fy = uy - m[2] * fz;
    const T fx = ux - m[0] * fy + m[1] * fz;
    r[0] = ceres::sqrt(fx * fx + fy * fy + fz * fz) - T(g);
    return true;
  }
};

template <typename T>
void mulQuat(const T* a, const T* b, T* out) {  // Hamilton, [w x y z]
  out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}

// Rotation of body frame over a sequence of rate samples: q_{B0 <- Bn}; the gravity
// direction in the final frame is R^T u0.
template <typename T>
void integrate(const std::vector<Vec3>& rates, const std::vector<double>& dts, const T* s,
               const T* Minv, T* q) {
  q[0] = T(1.0);
  q[1] = q[2] = q[3] = T(0.0);
  for (std::size_t i = 0; i < rates.size(); ++i) {
    T u[3];
    for (int k = 0; k < 3; ++k) u[k] = T(rates[i][k]) / s[k];
    T phi[3];
    for (int r = 0; r < 3; ++r)
      phi[r] = (Minv[3 * r] * u[0] + Minv[3 * r + 1] * u[1] + Minv[3 * r + 2] * u[2]) * dts[i];
    const T a2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    const T c = T(1.0) - a2 / T(8.0);
    const T h = T(0.5) - a2 / T(48.0);
    const T dq[4] = {c, h * phi[0], h * phi[1], h * phi[2]};
    T n[4];
    mulQuat(q, dq, n);
    for (int k = 0; k < 4; ++k) q[k] = n[k];
  }
  const T norm = ceres::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int k = 0; k < 4; ++k) q[k] /= norm;
}

template <typename T>
void rotateInverse(const T* q, const Vec3& v, T* out) {  // R(q)^T v
  const T qi[4] = {q[0], -q[1], -q[2], -q[3]};
  const T p[4] = {T(0.0), T(v.x()), T(v.y()), T(v.z())};
  T t[4], r[4];
  mulQuat(qi, p, t);
  mulQuat(t, q, r);
  out[0] = r[1];
  out[1] = r[2];
  out[2] = r[3];
}

template <typename T>
void misInverse(const T* m, T* Minv) {
  // M from eq.(1), then its inverse by the adjugate.
  const T M[9] = {T(1.0), m[0], -m[1], -m[2], T(1.0), m[3], m[4], -m[5], T(1.0)};
  const T c00 = M[4] * M[8] - M[5] * M[7], c01 = M[5] * M[6] - M[3] * M[8],
          c02 = M[3] * M[7] - M[4] * M[6];
  const T det = M[0] * c00 + M[1] * c01 + M[2] * c02;
  Minv[0] = c00 / det;
  Minv[1] = (M[2] * M[7] - M[1] * M[8]) / det;
  Minv[2] = (M[1] * M[5] - M[2] * M[4]) / det;
  Minv[3] = c01 / det;
  Minv[4] = (M[0] * M[8] - M[2] * M[6]) / det;
  Minv[5] = (M[2] * M[3] - M[0] * M[5]) / det;
  Minv[6] = c02 / det;
  Minv[7] = (M[1] * M[6] - M[0] * M[7]) / det;
  Minv[8] = (M[0] * M[4] - M[1] * M[3]) / det;
}

struct Rotation {
  std::vector<Vec3> rates;  // bias-removed readings
  std::vector<double> dts;
  Vec3 u0, u1;  // calibrated gravity directions before / after (body frame)
};

struct GyroDirCost {
  const Rotation* rot;
  template <typename T>
  bool operator()(const T* s, const T* m, T* r) const {
    T Minv[9];
    misInverse(m, Minv);
    T q[4];
    integrate(rot->rates, rot->dts, s, Minv, q);
    T u[3];
    rotateInverse(q, rot->u0, u);
    for (int k = 0; k < 3; ++k) r[k] = T(rot->u1[k]) - u[k];
    return true;
  }
};

double gyroCost(const std::vector<Rotation>& rots, const double* s, const double* m) {
  double sum = 0.0;
  for (const Rotation& rot : rots) {
    double r[3];
    GyroDirCost{&rot}(s, m, r);
    sum += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  }
  return sum;
}

// Dense Jacobian of a problem at its current point.
Eigen::MatrixXd problemJacobian(ceres::Problem& problem) {
  ceres::CRSMatrix crs;
  ceres::Problem::EvaluateOptions eo;
  problem.Evaluate(eo, nullptr, nullptr, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[static_cast<std::size_t>(r)];
         k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k)
      J(r, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
  return J;
}

// Sigmas from (J^T J)^-1 scaled by the residual variance. A direction the data carry no
// information along makes the fit arbitrary there: *unresolved names it (empty: none).
Eigen::VectorXd sigmasAndNotes(ceres::Problem& problem, double final_cost, int n_res,
                               const std::vector<std::string>& names, std::string* unresolved) {
  const Eigen::MatrixXd J = problemJacobian(problem);
  const int p = static_cast<int>(J.cols());
  Eigen::VectorXd sig = Eigen::VectorXd::Zero(p);
  if (p == 0) return sig;
  const InformationAnalysis ia = analyseInformation(J, names);
  for (const NullDirection& d : ia.null_directions)
    *unresolved += (unresolved->empty() ? "" : "; ") + d.description;
  const double dof = std::max(1, n_res - p);
  const double s2 = 2.0 * final_cost / dof;
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(JtJ);
  const double lmax = es.eigenvalues().maxCoeff();
  Eigen::MatrixXd inv = Eigen::MatrixXd::Zero(p, p);
  for (int k = 0; k < p; ++k) {
    const double l = es.eigenvalues()(k);
    if (l > 1e-12 * lmax)
      inv += es.eigenvectors().col(k) * es.eigenvectors().col(k).transpose() / l;
  }
  for (int k = 0; k < p; ++k) sig(k) = std::sqrt(std::max(0.0, inv(k, k) * s2));
  return sig;
}

// Physical-unit data: every static pose's |f| near g, else the columns are not what the header
// says (or the unit is wrong).
RecordingCheck checkSiGravity(const std::vector<Vec3>& acc_means,
                              const std::vector<StaticSpan>& spans, double g, double tol) {
  for (std::size_t k = 0; k < acc_means.size(); ++k) {
    const double n = acc_means[k].norm();
    if (std::abs(n - g) > tol * g) {
      std::ostringstream s;
      s << "static pose at t = " << spans[k].t0 << " .. " << spans[k].t1 << " s reads |f| = " << n
        << " m/s^2, far from g = " << g << " (tolerance " << tol * 100.0
        << " %): the accelerometer columns hold something else (swapped columns or a wrong "
           "unit?)";
      return RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
    }
  }
  return RecordingCheck::Ok();
}

// The fitted accelerometer must be well conditioned by the poses: the static scatter in the
// calibrated unit small against g, and every axis tilted both ways.
RecordingCheck checkAccelGeometry(const RawImuData& data, const std::vector<StaticSpan>& spans,
                                  const std::vector<Vec3>& acc_means, const TriadModel& acc,
                                  const ScalarCalibrationOptions& o) {
  double sum2 = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < spans.size(); ++k)
    for (std::size_t i = spans[k].begin; i < spans[k].end; ++i, ++n)
      sum2 += (acc.input(data.accel[i]) - acc.input(acc_means[k])).squaredNorm() / 3.0;
  const double scatter = n > 0 ? std::sqrt(sum2 / static_cast<double>(n)) : 0.0;
  std::ostringstream s;
  if (scatter > o.max_static_scatter_g * o.gravity_mps2) {
    s << "the static readings scatter by " << scatter << " m/s^2 per sample in the fitted unit ("
      << scatter / o.gravity_mps2 * 100.0
      << " % of g): the poses hardly change the gravity direction (one orientation, or the "
         "columns are not the accelerometer's), so the scales would be fitted to noise";
    return RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
  }
  Vec3 lo = Vec3::Constant(2.0), hi = Vec3::Constant(-2.0);
  for (const Vec3& a : acc_means) {
    const Vec3 u = acc.input(a).normalized();
    lo = lo.cwiseMin(u);
    hi = hi.cwiseMax(u);
  }
  for (int k = 0; k < 3; ++k)
    if (hi[k] - lo[k] < o.min_axis_span) {
      s << "accelerometer axis "
        << "xyz"[k] << " sees gravity components only in [" << lo[k] << ", " << hi[k]
        << "] g over the static poses (span " << hi[k] - lo[k] << " < " << o.min_axis_span
        << "): its scale and bias cannot be told apart; tilt that axis up and down";
      return RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
    }
  return RecordingCheck::Ok();
}

// Honest sigma of the gyro bias taken from the first pose: the white noise of its mean, the
// part of the Earth rate the pose cannot tell from the bias (the horizontal part, unknown
// heading; all of it when the latitude is unknown), and the bias drift seen between poses
// (the scatter of every pose's rest reading about the first, which the single bias cannot
// follow), added in quadrature, in rad/s.
Vec3 gyroBiasSigma(const TriadModel& gyr, const Vec3& white_mean_reading,
                   const std::vector<Vec3>& gyr_means, const Vec3& up_B,
                   const ScalarCalibrationOptions& o) {
  Vec3 var = white_mean_reading.cwiseQuotient(gyr.scale).cwiseAbs2();
  for (int k = 0; k < 3; ++k) {
    const double earth_var = o.latitude_rad
                                 ? std::pow(nav::kEarthRate * std::cos(*o.latitude_rad), 2) *
                                       (1.0 - up_B[k] * up_B[k]) / 2.0
                                 : nav::kEarthRate * nav::kEarthRate / 3.0;
    var[k] += earth_var;
  }
  if (gyr_means.size() > 1) {
    Vec3 drift = Vec3::Zero();
    for (const Vec3& gm : gyr_means)
      drift += (gm - gyr_means.front()).cwiseQuotient(gyr.scale).cwiseAbs2();
    var += drift / static_cast<double>(gyr_means.size() - 1);
  }
  return var.cwiseSqrt();
}

}  // namespace

ScalarCalibrationResult scalarCalibrate(const RawImuData& data, const ScalarCalibrationOptions& o,
                                        bool accel_unit_is_si) {
  ScalarCalibrationResult res;
  std::string why;
  if (!o.IsValid(&why)) {
    res.status = RecordingCheck::Error(RecordingStatusCode::kBadOptions, why);
    return res;
  }
  res.status = checkRecording(data, o.checks);
  if (!res.status.ok()) return res;
  StaticDetectionResult det = detectStaticSpans(data, o.detection);
  if (!det.status.ok()) {
    res.status = det.status;
    return res;
  }
  res.spans = det.spans;
  const auto& spans = res.spans;
  if (spans.front().duration() < o.min_initial_static_s) {
    std::ostringstream s;
    s << "first static interval (t = " << spans.front().t0 << " .. " << spans.front().t1
      << " s) lasts " << spans.front().duration() << " s, need >= " << o.min_initial_static_s
      << " s for the gyro bias";
    res.status = RecordingCheck::Error(RecordingStatusCode::kTooShortStatic, s.str());
    return res;
  }
  const int n_poses = static_cast<int>(spans.size());
  if (n_poses < o.min_poses_diagonal_accel) {
    std::ostringstream s;
    s << "found " << n_poses << " static poses, need >= " << o.min_poses_diagonal_accel
      << " for accelerometer scales and biases";
    res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
    return res;
  }

  // Trimmed span means.
  std::vector<Vec3> acc_means, gyr_means;
  for (const StaticSpan& sp : spans) {
    StaticSpan t = sp;
    while (t.begin + 2 < t.end && data.t[t.begin] < sp.t0 + o.span_trim_s) ++t.begin;
    while (t.end > t.begin + 2 && data.t[t.end - 1] > sp.t1 - o.span_trim_s) --t.end;
    acc_means.push_back(spanMean(data.accel, t));
    gyr_means.push_back(spanMean(data.gyro, t));
  }

  // ---- Accelerometer ----
  const double g = o.gravity_mps2;
  if (accel_unit_is_si) {
    res.status = checkSiGravity(acc_means, spans, g, o.si_gravity_tolerance);
    if (!res.status.ok()) return res;
  }
  Vec3 lo = acc_means[0], hi = acc_means[0];
  for (const Vec3& a : acc_means) {
    lo = lo.cwiseMin(a);
    hi = hi.cwiseMax(a);
  }
  double s_acc[3], b_acc[3], m_acc[3] = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    s_acc[k] = (hi[k] - lo[k]) / (2.0 * g);
    if (!(s_acc[k] > 0.0)) {
      res.status = RecordingCheck::Error(
          RecordingStatusCode::kTooFewStatics,
          std::string("accelerometer axis ") + "xyz"[k] + " reads the same in every static pose");
      return res;
    }
    b_acc[k] = -0.5 * (hi[k] + lo[k]) / s_acc[k];
  }
  auto accRms = [&](const double* s, const double* b, const double* m) {
    double sum = 0.0;
    for (const Vec3& a : acc_means) {
      double r;
      AccelNormCost{a, g}(s, b, m, &r);
      sum += r * r;
    }
    return std::sqrt(sum / static_cast<double>(acc_means.size()));
  };
  if (accel_unit_is_si) {
    const double one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
    res.accel_rms_before = accRms(one, zero, zero);
  } else {
    res.accel_rms_before = accRms(s_acc, b_acc, m_acc);
    res.notes.push_back(
        "accel 'before' RMS uses the per-axis min/max initial estimate (raw units)");
  }
  // Poses count by distinct gravity directions: a hand session holds the same face before and
  // after a rotation, and repeats add averaging, not geometry (13 spans over 6 faces would
  // otherwise pass for a 12-pose design and leave the misalignments unconditioned).
  int n_directions = 0;
  {
    std::vector<Vec3> dirs;
    const double cos_same = std::cos(o.same_pose_angle_deg * kDegToRad);
    for (const Vec3& a : acc_means) {
      Vec3 d;
      for (int k = 0; k < 3; ++k) d[k] = a[k] / s_acc[k] + b_acc[k];
      d.normalize();
      bool seen = false;
      for (const Vec3& e : dirs) seen = seen || d.dot(e) > cos_same;
      if (!seen) dirs.push_back(d);
    }
    n_directions = static_cast<int>(dirs.size());
  }
  if (n_directions < o.min_poses_diagonal_accel) {
    std::ostringstream s;
    s << "only " << n_directions << " distinct gravity directions among " << n_poses
      << " static poses: the accelerometer's 3 scales and 3 biases need >= "
      << o.min_poses_diagonal_accel << " (hold each axis up and down)";
    res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
    return res;
  }
  const bool full_accel = n_directions >= o.min_poses_full_accel;
  {
    ceres::Problem problem;
    for (const Vec3& a : acc_means)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<AccelNormCost, 1, 3, 3, 3>(new AccelNormCost{a, g}),
          nullptr, s_acc, b_acc, m_acc);
    if (!full_accel) {
      problem.SetParameterBlockConstant(m_acc);
      std::ostringstream s;
      s << "only " << n_directions << " distinct gravity directions among " << n_poses
        << " static poses (< " << o.min_poses_full_accel
        << "): accelerometer misalignments fixed at 0 and flagged unobservable";
      res.notes.push_back(s.str());
    }
    ceres::Solver::Options so;
    so.max_num_iterations = 200;
    so.function_tolerance = 1e-14;
    so.parameter_tolerance = 1e-14;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
    if (!sum.IsSolutionUsable()) {
      res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics,
                                         "accelerometer solve failed: " + sum.message);
      return res;
    }
    std::vector<std::string> names = {"accel.scale.x", "accel.scale.y", "accel.scale.z",
                                      "accel.bias.x",  "accel.bias.y",  "accel.bias.z"};
    if (full_accel)
      names.insert(names.end(),
                   {"accel.misalignment.xy", "accel.misalignment.xz", "accel.misalignment.yz"});
    std::string unresolved;
    const Eigen::VectorXd sig =
        sigmasAndNotes(problem, sum.final_cost, n_poses, names, &unresolved);
    if (!unresolved.empty()) {
      res.status = RecordingCheck::Error(
          RecordingStatusCode::kTooFewStatics,
          "the static poses do not determine the accelerometer: no information along " +
              unresolved + " (hold each axis up and down, and tilted between)");
      return res;
    }
    TriadModel& acc = res.report.values.sensors.accel;
    for (int k = 0; k < 3; ++k) {
      acc.scale[k] = s_acc[k];
      acc.bias[k] = b_acc[k];
      res.report.setSigma(names[static_cast<std::size_t>(k)], sig(k));
      res.report.setSigma(names[static_cast<std::size_t>(3 + k)], sig(3 + k));
    }
    acc.mis.xy = m_acc[0];
    acc.mis.xz = m_acc[1];
    acc.mis.yz = m_acc[2];
    if (full_accel) {
      for (int k = 6; k < 9; ++k) res.report.setSigma(names[static_cast<std::size_t>(k)], sig(k));
    } else {
      for (const char* m : {"xy", "xz", "yz"})
        res.report.setUnobservable(std::string("accel.misalignment.") + m);
    }
    for (const char* m : {"yx", "zx", "zy"})
      res.report.setUnobservable(std::string("accel.misalignment.") + m);
    res.notes.push_back(
        "accel misalignments yx, zx, zy fixed at 0: |f| = g cannot see a rotation of the triad; "
        "the instrument frame is defined by the accelerometers (z axis, y in the yz plane)");
    res.accel_rms_after = accRms(s_acc, b_acc, m_acc);
  }
  res.status = checkAccelGeometry(data, spans, acc_means, res.accel(), o);
  if (!res.status.ok()) return res;

  // ---- Gyro ----
  const Vec3 gyro_offset = gyr_means.front();  // raw reading at rest in the first pose
  std::vector<Vec3> u;
  for (const Vec3& a : acc_means) u.push_back(res.accel().input(a).normalized());
  std::vector<Rotation> rots;
  for (std::size_t k = 0; k + 1 < spans.size(); ++k) {
    Rotation r;
    // The gyro bias drifts between poses (MEMS: 0.1-1 mrad/s over a session): during the
    // rotation it is taken as the straight line between the rest readings of the poses before
    // and after, each of which holds that pose's bias (and its small Earth-rate projection).
    const double ta = data.t[spans[k].end - 1], tb = data.t[spans[k + 1].begin];
    for (std::size_t i = spans[k].end; i <= spans[k + 1].begin && i < data.size(); ++i) {
      const double w = tb > ta ? std::clamp((data.t[i] - ta) / (tb - ta), 0.0, 1.0) : 0.0;
      const Vec3 offset = o.interpolate_gyro_bias
                              ? Vec3((1.0 - w) * gyr_means[k] + w * gyr_means[k + 1])
                              : gyro_offset;
      r.rates.push_back(data.gyro[i] - offset);
      r.dts.push_back(data.t[i] - data.t[i - 1]);
    }
    r.u0 = u[k];
    r.u1 = u[k + 1];
    if (std::acos(std::clamp(r.u0.dot(r.u1), -1.0, 1.0)) < 5.0 * kDegToRad) continue;
    rots.push_back(std::move(r));
  }
  res.rotations_used = static_cast<int>(rots.size());
  double s_g[3], m_g[6] = {0, 0, 0, 0, 0, 0};
  if (rots.size() < 3) {
    std::ostringstream s;
    s << "only " << rots.size()
      << " rotations change the gravity direction by > 5 deg: gyro scale and misalignment "
         "not estimated";
    res.notes.push_back(s.str());
    for (const char* a : kAxisNames) res.report.setUnobservable(std::string("gyro.scale.") + a);
    for (const char* m : {"xy", "xz", "yx", "yz", "zx", "zy"})
      res.report.setUnobservable(std::string("gyro.misalignment.") + m);
    return res;
  }
  double s0 = o.gyro_scale_guess.value_or(0.0);
  if (!o.gyro_scale_guess) {
    double best = std::numeric_limits<double>::infinity();
    for (int e = -36; e <= 72; ++e) {  // 10^-3 .. 10^6 in 1/12-decade steps
      const double sc = std::pow(10.0, e / 12.0);
      const double ss[3] = {sc, sc, sc};
      const double c = gyroCost(rots, ss, m_g);
      if (c < best) {
        best = c;
        s0 = sc;
      }
    }
  }
  for (double& x : s_g) x = s0;
  const double n_dir = 3.0 * static_cast<double>(rots.size());
  res.gyro_rms_before = std::sqrt(gyroCost(rots, s_g, m_g) / n_dir);
  {
    ceres::Problem problem;
    for (const Rotation& r : rots)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<GyroDirCost, 3, 3, 6>(new GyroDirCost{&r}), nullptr, s_g,
          m_g);
    ceres::Solver::Options so;
    so.max_num_iterations = 100;
    so.function_tolerance = 1e-12;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
    if (!sum.IsSolutionUsable()) {
      res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics,
                                         "gyro solve failed: " + sum.message);
      return res;
    }
    std::vector<std::string> names = {"gyro.scale.x", "gyro.scale.y", "gyro.scale.z"};
    for (const char* m : {"xy", "xz", "yx", "yz", "zx", "zy"})
      names.push_back(std::string("gyro.misalignment.") + m);
    std::string unresolved;
    const Eigen::VectorXd sig =
        sigmasAndNotes(problem, sum.final_cost, static_cast<int>(n_dir), names, &unresolved);
    if (!unresolved.empty()) {
      std::ostringstream s;
      s << "the " << rots.size()
        << " rotations between static poses do not determine the gyro scales and "
           "misalignments (each gives two gravity-direction components; a full turn gives "
           "none): no information along "
        << unresolved << " (rotate about each axis by less than a full turn between poses)";
      res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
      return res;
    }
    for (std::size_t k = 0; k < names.size(); ++k)
      res.report.setSigma(names[k], sig(static_cast<Eigen::Index>(k)));
    TriadModel& gyr = res.report.values.sensors.gyro;
    gyr.scale = Vec3(s_g[0], s_g[1], s_g[2]);
    gyr.mis = Misalignment{m_g[0], m_g[1], m_g[2], m_g[3], m_g[4], m_g[5]};
    res.gyro_rms_after = std::sqrt(2.0 * sum.final_cost / n_dir);
    if (res.gyro_rms_after > o.max_gyro_rms_rad) {
      std::ostringstream s;
      s << "the integrated gyro rotations miss the gravity-direction changes by "
        << res.gyro_rms_after
        << " rad RMS after the fit: the gyro axes do not match the accelerometer's (swapped or "
           "mirrored columns?) or the motion between poses is not captured";
      res.status = RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
      return res;
    }
  }
  // reading = s (M w - b) with w ~ 0 at rest: b = -offset / s (Earth rate neglected).
  TriadModel& gyr = res.report.values.sensors.gyro;
  gyr.bias = -gyro_offset.cwiseQuotient(gyr.scale);
  if (o.latitude_rad) {
    // At rest the gyro senses the Earth rate; its vertical part, Omega sin(lat) along the
    // sensed "up" (the first pose's specific force), is known and leaves the bias.
    const Vec3 up_B = res.accel().input(acc_means.front()).normalized();
    gyr.bias += gyr.M() * (nav::kEarthRate * std::sin(*o.latitude_rad) * up_B);
  }
  const double n0 = static_cast<double>(spans.front().end - spans.front().begin);
  Vec3 var = Vec3::Zero();
  for (std::size_t i = spans.front().begin; i < spans.front().end; ++i)
    var += (data.gyro[i] - gyro_offset).cwiseAbs2();
  const Vec3 bias_sigma = gyroBiasSigma(gyr, (var / n0).cwiseSqrt() / std::sqrt(n0), gyr_means,
                                        res.accel().input(acc_means.front()).normalized(), o);
  for (int k = 0; k < 3; ++k)
    res.report.setSigma(std::string("gyro.bias.") + kAxisNames[static_cast<std::size_t>(k)],
                        bias_sigma[k]);
  // Earth-rate invariant: at rest |w| = 7.29e-5 rad/s in every pose.
  double sc = 0.0;
  for (const Vec3& gm : gyr_means) sc += (gyr.input(gm) - gyr.input(gyro_offset)).squaredNorm();
  res.static_rate_scatter = std::sqrt(sc / static_cast<double>(gyr_means.size()));
  res.earth_rate_usable = res.static_rate_scatter < 0.2 * nav::kEarthRate;
  std::ostringstream s;
  s << "static gyro rates after removing the first-pose bias scatter by " << res.static_rate_scatter
    << " rad/s RMS vs Earth rate " << nav::kEarthRate << " rad/s: "
    << (res.earth_rate_usable ? "Earth-rate invariant usable"
                              : "bias instability/noise hides the Earth rate, invariant not used")
    << (o.latitude_rad ? "; the vertical Earth rate is removed from the gyro bias, the horizontal "
                         "part (unknown heading) and the drift between poses are in its sigma"
                       : "; the gyro bias includes the Earth-rate projection of the first pose "
                         "(give the latitude to remove its vertical part); the Earth rate and the "
                         "drift between poses are in its sigma");
  res.notes.push_back(s.str());
  return res;
}

namespace {

std::string describeTriad(const CoefficientReport& rep, const std::string& which) {
  const TriadModel& t = which == "accel" ? rep.values.sensors.accel : rep.values.sensors.gyro;
  std::ostringstream o;
  o.precision(6);
  auto value = [&](const std::string& name, double v) {
    o << name << " " << v;
    const auto it = rep.uncertainty.find(which + "." + name);
    if (it != rep.uncertainty.end()) {
      if (!it->second.observable) {
        o << " (unobservable, fixed)";
      } else if (it->second.sigma) {
        o << " +- " << *it->second.sigma;
      }
    }
    o << "; ";
  };
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) value(std::string("scale.") + kAxis[k], t.scale[k]);
  for (int k = 0; k < 3; ++k) value(std::string("bias.") + kAxis[k], t.bias[k]);
  const std::pair<const char*, double> m[6] = {{"xy", t.mis.xy}, {"xz", t.mis.xz},
                                               {"yx", t.mis.yx}, {"yz", t.mis.yz},
                                               {"zx", t.mis.zx}, {"zy", t.mis.zy}};
  for (const auto& [n, v] : m) value(std::string("misalignment.") + n, v);
  return o.str();
}

}  // namespace

std::string describe(const ScalarCalibrationResult& r) {
  std::ostringstream o;
  o << "static poses found: " << r.spans.size()
    << ", rotations used for the gyro: " << r.rotations_used << "\n"
    << "RMS |a| - g over static poses: before " << r.accel_rms_before << " m/s^2, after "
    << r.accel_rms_after << " m/s^2\n"
    << "gravity-direction mismatch RMS: before " << r.gyro_rms_before << ", after "
    << r.gyro_rms_after << "\n"
    << "accel (scale in reading units per m/s^2, bias m/s^2): " << describeTriad(r.report, "accel")
    << "\n"
    << "gyro (scale in reading units per rad/s, bias rad/s): " << describeTriad(r.report, "gyro")
    << "\n";
  for (const std::string& n : r.notes) o << "note: " << n << "\n";
  return o.str();
}

}  // namespace imubench::calib
