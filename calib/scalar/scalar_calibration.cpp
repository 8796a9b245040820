#include "calib/scalar/scalar_calibration.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "calib/model/sensor_equation.h"
#include "calib/observability.h"
#include "calib/option_check.h"
#include "calib/recording_checks.h"
#include "nav/earth.h"

namespace imubench::calib {

bool ScalarCalibrationOptions::IsValid(std::string* why) const {
  if (!(gravity_mps2 > 9.7 && gravity_mps2 < 9.9))
    return invalidOption(why, "gravity_mps2 must be in (9.7, 9.9)");
  if (!(held_accel_misalignment_prior_rad >= 0.0))
    return invalidOption(why, "held_accel_misalignment_prior_rad must be >= 0");
  if (gyro_scale_guess && !(*gyro_scale_guess > 0.0))
    return invalidOption(why, "gyro_scale_guess must be > 0");
  if (!(min_initial_static_s >= 0.0))
    return invalidOption(why, "min_initial_static_s must be >= 0");
  if (!(same_pose_angle_deg > 0.0 && same_pose_angle_deg < 90.0)) {
    if (why) *why = "same_pose_angle_deg must be in (0, 90)";
    return false;
  }
  if (min_poses_diagonal_accel < 6 || min_poses_full_accel < 9)
    return invalidOption(why, "pose minimums below the number of unknowns (6 diagonal, 9 full)");
  if (!(span_trim_s >= 0.0)) return invalidOption(why, "span_trim_s must be >= 0");
  if (!(si_gravity_tolerance > 0.0 && si_gravity_tolerance < 1.0))
    return invalidOption(why, "si_gravity_tolerance must be in (0, 1)");
  if (!(max_static_scatter_g > 0.0)) return invalidOption(why, "max_static_scatter_g must be > 0");
  if (!(min_axis_span >= 0.0 && min_axis_span <= 2.0))
    return invalidOption(why, "min_axis_span must be in [0, 2]");
  if (!(max_gyro_rms_rad > 0.0)) return invalidOption(why, "max_gyro_rms_rad must be > 0");
  for (const Solver* so : {&accel_solver, &gyro_solver})
    if (so->max_iterations < 1 || !(so->function_tolerance > 0.0) ||
        !(so->parameter_tolerance > 0.0))
      return invalidOption(why, "solver settings: iterations >= 1 and tolerances > 0");
  if ((gyro_range_radps && !(*gyro_range_radps > 0.0)) ||
      (accel_range_mps2 && !(*accel_range_mps2 > 0.0)))
    return invalidOption(why, "the IMU's ranges must be > 0");
  return detection.IsValid(why) && checks.IsValid(why);
}

namespace {

using model::kBias;
using model::kMis;
using model::kMisXY;
using model::kMisXZ;
using model::kMisYZ;
using model::kScale;
using model::kTriadSize;
using model::Mat3T;
using model::Vec3T;

// |f| = g at rest: the compensated static mean (calib/model/sensor_equation.h) has the
// magnitude of gravity. One triad block (kTriadSize); which entries vary is set by a manifold.
struct AccelNormCost {
  Vec3 a;
  double g;
  template <typename T>
  bool operator()(const T* triad, T* r) const {
    r[0] = model::input(triad, Vec3T<T>(a.cast<T>())).norm() - T(g);
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

// Rotation of the body frame over a sequence of bias-removed rate readings, compensated by
// the affine map u = G r (sensor_equation.h): q_{B0 <- Bn}; the gravity direction in the final
// frame is R^T u0.
template <typename T>
void integrate(const std::vector<Vec3>& rates, const std::vector<double>& dts, const Mat3T<T>& G,
               T* q) {
  q[0] = T(1.0);
  q[1] = q[2] = q[3] = T(0.0);
  for (std::size_t i = 0; i < rates.size(); ++i) {
    const Vec3T<T> phi = G * rates[i].cast<T>() * T(dts[i]);
    const T a2 = phi.squaredNorm();
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

struct Rotation {
  std::vector<Vec3> rates;  // bias-removed readings
  std::vector<double> dts;
  Vec3 u0, u1;  // calibrated gravity directions before / after (body frame)
};

// The integrated gyro carries the gravity direction of the pose before a rotation into the
// pose after it. One triad block whose bias entries stay 0 (the readings are bias-removed).
struct GyroDirCost {
  const Rotation* rot;
  template <typename T>
  bool operator()(const T* triad, T* r) const {
    Mat3T<T> G;
    Vec3T<T> h;
    model::compensationAffine(triad, &G, &h);
    T q[4];
    integrate(rot->rates, rot->dts, G, q);
    T u[3];
    rotateInverse(q, rot->u0, u);
    for (int k = 0; k < 3; ++k) r[k] = T(rot->u1[k]) - u[k];
    return true;
  }
};

double gyroCost(const std::vector<Rotation>& rots, const double* triad) {
  double sum = 0.0;
  for (const Rotation& rot : rots) {
    double r[3];
    GyroDirCost{&rot}(triad, r);
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

namespace {

using Triad = std::array<double, kTriadSize>;

// The static poses and their trimmed means (reading units).
struct Poses {
  std::vector<StaticSpan> spans;
  std::vector<Vec3> acc_means, gyr_means;
};

RecordingCheck refuse(const std::ostringstream& s) {
  return RecordingCheck::Error(RecordingStatusCode::kTooFewStatics, s.str());
}

// Checks, static detection, the initial static's length, the pose count and the means.
RecordingCheck findPoses(const RawImuData& data, const ScalarCalibrationOptions& o, Poses* p) {
  std::string why;
  if (!o.IsValid(&why)) return RecordingCheck::Error(RecordingStatusCode::kBadOptions, why);
  if (RecordingCheck c = checkRecording(data, o.checks); !c.ok) return c;
  StaticDetectionResult det = detectStaticSpans(data, o.detection);
  if (!det.status.ok) return det.status;
  p->spans = det.spans;
  const StaticSpan& first = p->spans.front();
  std::ostringstream s;
  if (first.duration() < o.min_initial_static_s) {
    s << "first static interval (t = " << first.t0 << " .. " << first.t1 << " s) lasts "
      << first.duration() << " s, need >= " << o.min_initial_static_s << " s for the gyro bias";
    return RecordingCheck::Error(RecordingStatusCode::kTooShortStatic, s.str());
  }
  if (static_cast<int>(p->spans.size()) < o.min_poses_diagonal_accel) {
    s << "found " << p->spans.size() << " static poses, need >= " << o.min_poses_diagonal_accel
      << " for accelerometer scales and biases";
    return refuse(s);
  }
  for (const StaticSpan& sp : p->spans) {
    StaticSpan t = sp;
    while (t.begin + 2 < t.end && data.t[t.begin] < sp.t0 + o.span_trim_s) ++t.begin;
    while (t.end > t.begin + 2 && data.t[t.end - 1] > sp.t1 - o.span_trim_s) --t.end;
    p->acc_means.push_back(spanMean(data.accel, t));
    p->gyr_means.push_back(spanMean(data.gyro, t));
  }
  return RecordingCheck::Ok();
}

double accelRms(const std::vector<Vec3>& acc_means, double g, const Triad& triad) {
  double sum = 0.0;
  for (const Vec3& a : acc_means) {
    double r;
    AccelNormCost{a, g}(triad.data(), &r);
    sum += r * r;
  }
  return std::sqrt(sum / static_cast<double>(acc_means.size()));
}

// Per-axis scale and bias from the extreme readings (each axis up and down).
RecordingCheck initialAccel(const std::vector<Vec3>& acc_means, double g, Triad* triad) {
  Vec3 lo = acc_means[0], hi = acc_means[0];
  for (const Vec3& a : acc_means) {
    lo = lo.cwiseMin(a);
    hi = hi.cwiseMax(a);
  }
  triad->fill(0.0);
  for (int k = 0; k < 3; ++k) {
    (*triad)[kScale + k] = (hi[k] - lo[k]) / (2.0 * g);
    if (!((*triad)[kScale + k] > 0.0)) {
      return RecordingCheck::Error(
          RecordingStatusCode::kTooFewStatics,
          std::string("accelerometer axis ") + "xyz"[k] + " reads the same in every static pose");
    }
    (*triad)[kBias + k] = -0.5 * (hi[k] + lo[k]) / (*triad)[kScale + k];
  }
  return RecordingCheck::Ok();
}

// Poses count by distinct gravity directions: a hand session holds the same face before and
// after a rotation, and repeats add averaging, not geometry (13 spans over 6 faces would
// otherwise pass for a 12-pose design and leave the misalignments unconditioned).
int distinctDirections(const std::vector<Vec3>& acc_means, const Triad& guess, double angle_deg) {
  std::vector<Vec3> dirs;
  const double cos_same = std::cos(angle_deg * kDegToRad);
  for (const Vec3& a : acc_means) {
    const Vec3 d = model::input(guess.data(), Vec3T<double>(a)).normalized();
    bool seen = false;
    for (const Vec3& e : dirs) seen = seen || d.dot(e) > cos_same;
    if (!seen) dirs.push_back(d);
  }
  return static_cast<int>(dirs.size());
}

// Runs one fit with the options' solver settings; its final cost, or why it failed.
RecordingCheck solve(ceres::Problem& problem, const ScalarCalibrationOptions::Solver& settings,
                     const std::string& what, double* final_cost) {
  ceres::Solver::Options so;
  so.max_num_iterations = settings.max_iterations;
  so.function_tolerance = settings.function_tolerance;
  so.parameter_tolerance = settings.parameter_tolerance;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  *final_cost = sum.final_cost;
  if (sum.IsSolutionUsable()) return RecordingCheck::Ok();
  return RecordingCheck::Error(RecordingStatusCode::kTooFewStatics,
                               what + " solve failed: " + sum.message);
}

// Solves |f| = g over the poses for the free entries of `triad` (names, in block order), with
// sigmas; a direction the poses do not determine is a refusal.
RecordingCheck solveAccel(const std::vector<Vec3>& acc_means, const ScalarCalibrationOptions& o,
                          const std::vector<std::string>& names, const std::vector<int>& fixed,
                          Triad* triad, Eigen::VectorXd* sig) {
  ceres::Problem problem;
  for (const Vec3& a : acc_means)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AccelNormCost, 1, kTriadSize>(
                                 new AccelNormCost{a, o.gravity_mps2}),
                             nullptr, triad->data());
  problem.SetManifold(triad->data(), new ceres::SubsetManifold(kTriadSize, fixed));
  double final_cost = 0.0;
  if (RecordingCheck c = solve(problem, o.accel_solver, "accelerometer", &final_cost); !c.ok)
    return c;
  std::string unresolved;
  *sig =
      sigmasAndNotes(problem, final_cost, static_cast<int>(acc_means.size()), names, &unresolved);
  if (!unresolved.empty()) {
    return RecordingCheck::Error(
        RecordingStatusCode::kTooFewStatics,
        "the static poses do not determine the accelerometer: no information along " + unresolved +
            " (hold each axis up and down, and tilted between)");
  }
  return RecordingCheck::Ok();
}

// The accelerometer: scales and biases, and the upper misalignments (xy, xz, yz) when the
// poses hold enough distinct gravity directions; the instrument frame is the accelerometers'.
RecordingCheck fitAccel(const RawImuData& data, const Poses& p, const ScalarCalibrationOptions& o,
                        bool accel_unit_is_si, ScalarCalibrationResult* res) {
  const double g = o.gravity_mps2;
  if (accel_unit_is_si) {
    if (RecordingCheck c = checkSiGravity(p.acc_means, p.spans, g, o.si_gravity_tolerance); !c.ok)
      return c;
  }
  Triad acc;
  if (RecordingCheck c = initialAccel(p.acc_means, g, &acc); !c.ok) return c;
  if (accel_unit_is_si) {
    res->accel_rms_before = accelRms(p.acc_means, g, TriadModel{}.block());
  } else {
    res->accel_rms_before = accelRms(p.acc_means, g, acc);
    res->notes.push_back(
        "accel 'before' RMS uses the per-axis min/max initial estimate (raw units)");
  }
  const int n_poses = static_cast<int>(p.spans.size());
  const int n_directions = distinctDirections(p.acc_means, acc, o.same_pose_angle_deg);
  std::ostringstream s;
  if (n_directions < o.min_poses_diagonal_accel) {
    s << "only " << n_directions << " distinct gravity directions among " << n_poses
      << " static poses: the accelerometer's 3 scales and 3 biases need >= "
      << o.min_poses_diagonal_accel << " (hold each axis up and down)";
    return refuse(s);
  }
  const bool full_accel = n_directions >= o.min_poses_full_accel;
  std::vector<std::string> names = {"accel.scale.x", "accel.scale.y", "accel.scale.z",
                                    "accel.bias.x",  "accel.bias.y",  "accel.bias.z"};
  std::vector<int> fixed = {kMis + model::kMisYX, kMis + model::kMisZX, kMis + model::kMisZY};
  if (full_accel) {
    names.insert(names.end(),
                 {"accel.misalignment.xy", "accel.misalignment.xz", "accel.misalignment.yz"});
  } else {
    fixed.insert(fixed.end(), {kMis + kMisXY, kMis + kMisXZ, kMis + kMisYZ});
    s << "only " << n_directions << " distinct gravity directions among " << n_poses
      << " static poses (< " << o.min_poses_full_accel
      << "): accelerometer misalignments fixed at 0 and flagged unobservable";
    res->notes.push_back(s.str());
  }
  Eigen::VectorXd sig;
  if (RecordingCheck c = solveAccel(p.acc_means, o, names, fixed, &acc, &sig); !c.ok) return c;
  res->report.values.sensors.accel = TriadModel::fromBlock(acc.data());
  for (std::size_t k = 0; k < names.size(); ++k)
    res->report.setSigma(names[k], sig(static_cast<Eigen::Index>(k)));
  for (const char* m : {"xy", "xz", "yz"})
    if (!full_accel) res->report.setUnobservable(std::string("accel.misalignment.") + m);
  for (const char* m : {"yx", "zx", "zy"})
    res->report.setUnobservable(std::string("accel.misalignment.") + m);
  res->notes.push_back(
      "accel misalignments yx, zx, zy fixed at 0: |f| = g cannot see a rotation of the triad; "
      "the instrument frame is defined by the accelerometers (z axis, y in the yz plane)");
  res->accel_rms_after = accelRms(p.acc_means, g, acc);
  return checkAccelGeometry(data, p.spans, p.acc_means, res->accel(), o);
}

// The rotations between consecutive poses that change the gravity direction by > 5 deg, their
// readings with the gyro bias removed: the straight line between the rest readings of the
// poses before and after (MEMS biases drift 0.1-1 mrad/s over a session; each pose's rest
// reading holds its bias and its small Earth-rate projection), or the first pose's throughout.
std::vector<Rotation> rotationsBetweenPoses(const RawImuData& data, const Poses& p,
                                            const TriadModel& accel,
                                            const ScalarCalibrationOptions& o) {
  std::vector<Vec3> u;
  for (const Vec3& a : p.acc_means) u.push_back(accel.input(a).normalized());
  std::vector<Rotation> rots;
  for (std::size_t k = 0; k + 1 < p.spans.size(); ++k) {
    Rotation r;
    const double ta = data.t[p.spans[k].end - 1], tb = data.t[p.spans[k + 1].begin];
    for (std::size_t i = p.spans[k].end; i <= p.spans[k + 1].begin && i < data.size(); ++i) {
      const double w = tb > ta ? std::clamp((data.t[i] - ta) / (tb - ta), 0.0, 1.0) : 0.0;
      const Vec3 offset = o.interpolate_gyro_bias
                              ? Vec3((1.0 - w) * p.gyr_means[k] + w * p.gyr_means[k + 1])
                              : p.gyr_means.front();
      r.rates.push_back(data.gyro[i] - offset);
      r.dts.push_back(data.t[i] - data.t[i - 1]);
    }
    r.u0 = u[k];
    r.u1 = u[k + 1];
    if (std::acos(std::clamp(r.u0.dot(r.u1), -1.0, 1.0)) < 5.0 * kDegToRad) continue;
    rots.push_back(std::move(r));
  }
  return rots;
}

// Readings per rad/s when no guess is given: raw counts have no known unit, so a coarse 1-D
// search over 10^-3 .. 10^6 in 1/12-decade steps.
double gyroScaleGuess(const std::vector<Rotation>& rots, const ScalarCalibrationOptions& o) {
  if (o.gyro_scale_guess) return *o.gyro_scale_guess;
  double best = std::numeric_limits<double>::infinity(), s0 = 1.0;
  for (int e = -36; e <= 72; ++e) {
    const double sc = std::pow(10.0, e / 12.0);
    Triad t = TriadModel{}.block();
    for (int k = 0; k < 3; ++k) t[kScale + k] = sc;
    const double c = gyroCost(rots, t.data());
    if (c < best) {
      best = c;
      s0 = sc;
    }
  }
  return s0;
}

// Gyro scales and all six misalignments (relative to the accelerometers' frame) from the
// gravity-direction changes; a direction the rotations do not determine is a refusal.
RecordingCheck fitGyroGains(const std::vector<Rotation>& rots, const ScalarCalibrationOptions& o,
                            ScalarCalibrationResult* res) {
  Triad gyr = TriadModel{}.block();
  const double s0 = gyroScaleGuess(rots, o);
  for (int k = 0; k < 3; ++k) gyr[kScale + k] = s0;
  const double n_dir = 3.0 * static_cast<double>(rots.size());
  res->gyro_rms_before = std::sqrt(gyroCost(rots, gyr.data()) / n_dir);
  ceres::Problem problem;
  for (const Rotation& r : rots)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<GyroDirCost, 3, kTriadSize>(new GyroDirCost{&r}), nullptr,
        gyr.data());
  problem.SetManifold(gyr.data(),
                      new ceres::SubsetManifold(kTriadSize, {kBias, kBias + 1, kBias + 2}));
  double final_cost = 0.0;
  if (RecordingCheck c = solve(problem, o.gyro_solver, "gyro", &final_cost); !c.ok) return c;
  std::vector<std::string> names = {"gyro.scale.x", "gyro.scale.y", "gyro.scale.z"};
  for (const char* m : {"xy", "xz", "yx", "yz", "zx", "zy"})
    names.push_back(std::string("gyro.misalignment.") + m);
  std::string unresolved;
  const Eigen::VectorXd sig =
      sigmasAndNotes(problem, final_cost, static_cast<int>(n_dir), names, &unresolved);
  std::ostringstream s;
  if (!unresolved.empty()) {
    s << "the " << rots.size()
      << " rotations between static poses do not determine the gyro scales and "
         "misalignments (each gives two gravity-direction components; a full turn gives "
         "none): no information along "
      << unresolved << " (rotate about each axis by less than a full turn between poses)";
    return refuse(s);
  }
  for (std::size_t k = 0; k < names.size(); ++k)
    res->report.setSigma(names[k], sig(static_cast<Eigen::Index>(k)));
  res->report.values.sensors.gyro = TriadModel::fromBlock(gyr.data());
  res->gyro_rms_after = std::sqrt(2.0 * final_cost / n_dir);
  if (res->gyro_rms_after > o.max_gyro_rms_rad) {
    s << "the integrated gyro rotations miss the gravity-direction changes by "
      << res->gyro_rms_after
      << " rad RMS after the fit: the gyro axes do not match the accelerometer's (swapped or "
         "mirrored columns?) or the motion between poses is not captured";
    return refuse(s);
  }
  return RecordingCheck::Ok();
}

// The gyro bias from the first pose's rest reading (reading = s (M w - b) with w ~ 0 at rest,
// less the vertical Earth rate when the latitude is known) and its honest sigma.
void gyroBias(const RawImuData& data, const Poses& p, const ScalarCalibrationOptions& o,
              ScalarCalibrationResult* res) {
  TriadModel& gyr = res->report.values.sensors.gyro;
  const Vec3& gyro_offset = p.gyr_means.front();
  const Vec3 up_B = res->accel().input(p.acc_means.front()).normalized();
  gyr.bias = -gyro_offset.cwiseQuotient(gyr.scale);
  if (o.latitude_rad) gyr.bias += gyr.M() * (nav::kEarthRate * std::sin(*o.latitude_rad) * up_B);
  const StaticSpan& first = p.spans.front();
  const double n0 = static_cast<double>(first.end - first.begin);
  Vec3 var = Vec3::Zero();
  for (std::size_t i = first.begin; i < first.end; ++i)
    var += (data.gyro[i] - gyro_offset).cwiseAbs2();
  const Vec3 bias_sigma =
      gyroBiasSigma(gyr, (var / n0).cwiseSqrt() / std::sqrt(n0), p.gyr_means, up_B, o);
  for (int k = 0; k < 3; ++k)
    res->report.setSigma(std::string("gyro.bias.") + kAxisNames[static_cast<std::size_t>(k)],
                         bias_sigma[k]);
}

// Earth-rate invariant: at rest |w| = 7.29e-5 rad/s in every pose; usable only when the
// static rates scatter far less than that.
void earthRateNote(const Poses& p, const ScalarCalibrationOptions& o,
                   ScalarCalibrationResult* res) {
  const TriadModel& gyr = res->gyro();
  double sc = 0.0;
  for (const Vec3& gm : p.gyr_means)
    sc += (gyr.input(gm) - gyr.input(p.gyr_means.front())).squaredNorm();
  res->static_rate_scatter = std::sqrt(sc / static_cast<double>(p.gyr_means.size()));
  res->earth_rate_usable = res->static_rate_scatter < 0.2 * nav::kEarthRate;
  std::ostringstream s;
  s << "static gyro rates after removing the first-pose bias scatter by "
    << res->static_rate_scatter << " rad/s RMS vs Earth rate " << nav::kEarthRate << " rad/s: "
    << (res->earth_rate_usable ? "Earth-rate invariant usable"
                               : "bias instability/noise hides the Earth rate, invariant not used")
    << (o.latitude_rad ? "; the vertical Earth rate is removed from the gyro bias, the horizontal "
                         "part (unknown heading) and the drift between poses are in its sigma"
                       : "; the gyro bias includes the Earth-rate projection of the first pose "
                         "(give the latitude to remove its vertical part); the Earth rate and the "
                         "drift between poses are in its sigma");
  res->notes.push_back(s.str());
}

}  // namespace

namespace {

// The Schmidt consider term of the accelerometer misalignments held at 0 (too few gravity
// directions): each is set to a small step, the gravity directions and the gyro gains refitted,
// and the gyro coefficients' sensitivity S to it times the prior added to their variance. The
// accelerometer's scales and biases are kept: |f| = g is insensitive to these misalignments on
// the poses that cannot determine them (the reason they are held).
void considerHeldAccelMisalignments(const RawImuData& data, const Poses& p,
                                    const ScalarCalibrationOptions& o,
                                    ScalarCalibrationResult* res) {
  const auto held = res->report.uncertainty.find("accel.misalignment.xy");
  if (!(o.held_accel_misalignment_prior_rad > 0.0) || held == res->report.uncertainty.end() ||
      held->second.observable) {
    return;
  }
  constexpr double kStep = 1e-4;  // rad: linear against the prior, far above round-off
  ScalarCalibrationOptions so = o;
  so.gyro_scale_guess = res->gyro().scale.mean();
  std::map<std::string, double> added;  // variance
  for (const int m : {kMisXY, kMisXZ, kMisYZ}) {
    Triad acc = res->accel().block();
    acc[static_cast<std::size_t>(kMis + m)] += kStep;
    ScalarCalibrationResult moved;
    if (!fitGyroGains(rotationsBetweenPoses(data, p, TriadModel::fromBlock(acc.data()), so), so,
                      &moved)
             .ok) {
      continue;
    }
    for (const auto& [name, u] : moved.report.uncertainty) {
      const double s =
          (*flatValue(moved.report.values, name) - *flatValue(res->report.values, name)) / kStep *
          o.held_accel_misalignment_prior_rad;
      added[name] += s * s;
    }
  }
  for (const auto& [name, var] : added) {
    Uncertainty& u = res->report.uncertainty[name];
    if (u.sigma) u.sigma = std::sqrt(*u.sigma * *u.sigma + var);
  }
  std::ostringstream s;
  s << "the accelerometer misalignments held at 0 are in the gyro scales' and misalignments' "
       "sigmas (consider term, prior "
    << o.held_accel_misalignment_prior_rad << " rad each)";
  res->notes.push_back(s.str());
}

// The range refusal in the IMU's terms ("--gyro-range").
RecordingCheck fromRangeCheck(RecordingCheck c) {
  if (!c.ok) c.message += " (the IMU's range as given: --gyro-range/--accel-range)";
  return c;
}

}  // namespace

ScalarCalibrationResult scalarCalibrate(const RawImuData& data, const ScalarCalibrationOptions& o,
                                        bool accel_unit_is_si) {
  ScalarCalibrationResult res;
  Poses p;
  res.status = findPoses(data, o, &p);
  if (!res.status.ok) return res;
  res.spans = p.spans;
  res.status = fitAccel(data, p, o, accel_unit_is_si, &res);
  if (!res.status.ok) return res;
  RangeCheckOptions accel_range;
  accel_range.accel_range_mps2 = o.accel_range_mps2;
  res.status = fromRangeCheck(checkCalibratedRanges(data, res.accel(), res.gyro(), accel_range));
  if (!res.status.ok) return res;
  const std::vector<Rotation> rots = rotationsBetweenPoses(data, p, res.accel(), o);
  res.rotations_used = static_cast<int>(rots.size());
  if (rots.size() < 3) {
    if (o.gyro_range_radps) {
      res.notes.push_back("the gyro range was not checked: the gyro scale is not estimated");
    }
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
  res.status = fitGyroGains(rots, o, &res);
  if (!res.status.ok) return res;
  considerHeldAccelMisalignments(data, p, o, &res);
  gyroBias(data, p, o, &res);
  RangeCheckOptions gyro_range;
  gyro_range.gyro_range_radps = o.gyro_range_radps;
  res.status = fromRangeCheck(checkCalibratedRanges(data, res.accel(), res.gyro(), gyro_range));
  if (!res.status.ok) return res;
  earthRateNote(p, o, &res);
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
