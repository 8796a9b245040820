#include "calib/direct_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "calib/observability.h"
#include "calib/static_detection.h"

namespace imubench::calib {

bool DirectCalibrationOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(static_trim_s >= 0.0)) return fail("static_trim_s must be >= 0");
  if (!(min_static_s > 0.0)) return fail("min_static_s must be > 0");
  if (!(min_rotation_rad > 0.0)) return fail("min_rotation_rad must be > 0");
  return checks.IsValid(why);
}

namespace {

constexpr std::array<const char*, 3> kAxis = {"x", "y", "z"};

// Encoder angles at time t, linear between samples, held outside.
TableAngles anglesAt(const std::vector<TableSample>& table, double t) {
  auto it = std::lower_bound(table.begin(), table.end(), t,
                             [](const TableSample& s, double v) { return s.t < v; });
  if (it == table.begin()) return table.front().angles;
  if (it == table.end()) return table.back().angles;
  const TableSample& b = *it;
  const TableSample& a = *(it - 1);
  const double w = (t - a.t) / (b.t - a.t);
  return {a.angles.outer + w * (b.angles.outer - a.angles.outer),
          a.angles.middle + w * (b.angles.middle - a.angles.middle),
          a.angles.inner + w * (b.angles.inner - a.angles.inner)};
}

// Encoder angles of the table at rest just outside a motion that starts at t (before = true:
// the last sample at or before t) or ends at t (the first sample at or after t). A sample
// taken during the motion's ramps must not be interpolated: the angle is quadratic there.
TableAngles restAngles(const std::vector<TableSample>& table, double t, bool before) {
  if (before) {
    auto it = std::upper_bound(table.begin(), table.end(), t,
                               [](double v, const TableSample& s) { return v < s.t; });
    return it == table.begin() ? table.front().angles : (it - 1)->angles;
  }
  auto it = std::lower_bound(table.begin(), table.end(), t,
                             [](const TableSample& s, double v) { return s.t < v; });
  return it == table.end() ? table.back().angles : it->angles;
}

double axisAngle(const TableAngles& a, TableKind kind, int axis) {
  if (axis == 0) return a.outer;
  if (kind == TableKind::kThreeAxis && axis == 1) return a.middle;
  return a.inner;
}

// Unit rotation axis of `axis` in B for the (nominal or known-error) table at the given angles.
Vec3 axisInBody(const TableModel& nominal, const TableAngles& a, int axis) {
  TableState st;
  st.outer.angle = a.outer;
  st.middle.angle = a.middle;
  st.inner.angle = a.inner;
  const TableKind kind = nominal.geometry().kind;
  if (axis == 0)
    st.outer.rate = 1.0;
  else if (kind == TableKind::kThreeAxis && axis == 1)
    st.middle.rate = 1.0;
  else
    st.inner.rate = 1.0;
  return nominal.kinematics(st).w_LB_B;
}

struct Rows {
  std::vector<Vec3> input;       // regressor (SI input)
  std::vector<Vec3> reading;     // mean reading
  std::vector<Vec3> reading_se;  // standard error of the mean reading (white sensor noise)
  std::vector<std::string> what;
  std::vector<bool> is_static;
  std::vector<Vec3> up_B;  // static rows: the nominal Up direction in B
};

enum class TriadKind { kAccel, kGyro };

// Seed's classic estimator for one axis i: the static positions with axis i up and down.
// Returns false when the plan has no such pair.
bool axisPairs(const Rows& rows, int i, std::vector<std::size_t>* up,
               std::vector<std::size_t>* down) {
  const double cos_tol = std::cos(2.0 * kDegToRad);
  for (std::size_t j = 0; j < rows.input.size(); ++j) {
    if (!rows.is_static[j]) continue;
    if (rows.up_B[j][i] > cos_tol) up->push_back(j);
    if (rows.up_B[j][i] < -cos_tol) down->push_back(j);
  }
  return !up->empty() && !down->empty();
}

// Per-axis least squares of reading_i = K_i . input + o_i; fills the triad, sigmas and flags.
void fitTriad(const Rows& rows, TriadKind kind, bool pairwise, const std::string& triad,
              TriadModel* out, CoefficientReport* report, std::vector<std::string>* notes,
              double* rms) {
  const Eigen::Index n = static_cast<Eigen::Index>(rows.input.size());
  Eigen::MatrixXd X(n, 4);
  for (Eigen::Index j = 0; j < n; ++j) {
    X.block<1, 3>(j, 0) = rows.input[static_cast<std::size_t>(j)].transpose();
    X(j, 3) = 1.0;
  }
  // Names of K_i's entries: diagonal -> scale, off-diagonal -> misalignment (the model's
  // kMisEntries: which entry of M, with which sign), o -> bias.
  auto misEntry = [](int row, int col) {
    return model::kMisEntries[static_cast<std::size_t>(model::misalignmentAt(row, col))];
  };
  // Variance of the mean over `idx` rows of axis i's reading, and per-row weights.
  auto meanVar = [&](const std::vector<std::size_t>& idx, int i) {
    double v = 0.0;
    for (std::size_t j : idx) v += rows.reading_se[j][i] * rows.reading_se[j][i];
    return v / (static_cast<double>(idx.size()) * static_cast<double>(idx.size()));
  };
  auto rowWeights = [&](int i) {
    Eigen::VectorXd w(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      const double se = rows.reading_se[static_cast<std::size_t>(j)][i];
      w(j) = se > 0.0 ? 1.0 / (se * se) : 1.0;
    }
    return w;
  };
  double ss = 0.0;
  Mat3 K = Mat3::Identity();
  Vec3 o = Vec3::Zero();
  std::array<double, model::kMisCount> mis{};
  for (int i = 0; i < 3; ++i) {
    std::vector<std::string> names;
    for (int c = 0; c < 3; ++c)
      names.push_back(c == i ? triad + ".scale." + kAxis[static_cast<std::size_t>(i)]
                             : triad + ".misalignment." + misEntry(i, c).name);
    names.push_back(triad + ".bias." + kAxis[static_cast<std::size_t>(i)]);
    Eigen::VectorXd y(n);
    for (Eigen::Index j = 0; j < n; ++j) y(j) = rows.reading[static_cast<std::size_t>(j)][i];
    const InformationAnalysis ia = analyseInformation(X, names);
    Eigen::Vector4d beta;
    std::vector<std::size_t> up, down;
    Eigen::Matrix4d cov_pair = Eigen::Matrix4d::Zero();
    bool have_cov_pair = false;
    if (pairwise && axisPairs(rows, i, &up, &down)) {
      // Scale/offset from the axis-up/axis-down positions (a table error tilts the input
      // there only to second order), the rest by least squares with them held.
      auto mean = [&](const std::vector<std::size_t>& idx, const Eigen::Vector4d& b, int skip) {
        double m = 0.0;
        for (std::size_t j : idx) {
          double v = y(static_cast<Eigen::Index>(j));
          for (int c = 0; c < 3; ++c)
            if (c != skip) v -= b(c) * rows.input[j][c];
          m += v;
        }
        return m / static_cast<double>(idx.size());
      };
      beta.setZero();
      beta(i) = 1.0;
      for (int iter = 0; iter < 4; ++iter) {
        const double U = mean(up, beta, kind == TriadKind::kAccel ? i : -1);
        const double D = mean(down, beta, kind == TriadKind::kAccel ? i : -1);
        if (kind == TriadKind::kAccel) {
          double gu = 0.0, gd = 0.0;
          for (std::size_t j : up) gu += rows.input[j][i] / static_cast<double>(up.size());
          for (std::size_t j : down) gd += rows.input[j][i] / static_cast<double>(down.size());
          beta(i) = (U - D) / (gu - gd);
          beta(3) = U - beta(i) * gu;
          // Off-diagonal terms from every static position, scale and offset held.
          Eigen::MatrixXd A(n, 2);
          Eigen::VectorXd z(n);
          const int c1 = (i + 1) % 3, c2 = (i + 2) % 3;
          for (Eigen::Index j = 0; j < n; ++j) {
            const Vec3& f = rows.input[static_cast<std::size_t>(j)];
            A(j, 0) = f[c1];
            A(j, 1) = f[c2];
            z(j) = y(j) - beta(3) - beta(i) * f[i];
          }
          const Eigen::Vector2d m2 = A.colPivHouseholderQr().solve(z);
          beta(c1) = m2(0);
          beta(c2) = m2(1);
          // Covariance from the sensor noise (the residual scatter also holds the table
          // errors, which are a bias of the misalignments, not noise): U, D are means of the
          // up/down rows; the off-diagonal fit adds its own noise and that of (scale, offset).
          const double varU = meanVar(up, i), varD = meanVar(down, i);
          const double den = gu - gd;
          Eigen::Matrix2d J_so;  // d(scale, offset)/d(U, D)
          J_so << 1.0 / den, -1.0 / den, -gd / den, gu / den;
          const Eigen::Matrix2d cov_so =
              J_so * Eigen::Vector2d(varU, varD).asDiagonal() * J_so.transpose();
          const Eigen::VectorXd w = rowWeights(i);
          const Eigen::Matrix2d N = A.transpose() * w.asDiagonal() * A;
          const Eigen::Matrix2d Ninv = N.inverse();
          Eigen::MatrixXd B(n, 2);  // dz/d(scale, offset)
          for (Eigen::Index j = 0; j < n; ++j) {
            B(j, 0) = -rows.input[static_cast<std::size_t>(j)][i];
            B(j, 1) = -1.0;
          }
          const Eigen::Matrix2d G = Ninv * A.transpose() * w.asDiagonal() * B;
          const Eigen::Matrix2d cov_m = Ninv + G * cov_so * G.transpose();
          const Eigen::Matrix2d cov_m_so = G * cov_so;
          const int idx[4] = {i, 3, c1, c2};
          Eigen::Matrix4d C = Eigen::Matrix4d::Zero();
          C.block<2, 2>(0, 0) = cov_so;
          C.block<2, 2>(2, 2) = cov_m;
          C.block<2, 2>(2, 0) = cov_m_so;
          C.block<2, 2>(0, 2) = cov_m_so.transpose();
          for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) cov_pair(idx[a], idx[b]) = C(a, b);
          have_cov_pair = true;
        } else {
          // Gyro: offset from the pair (Earth-rate inputs removed with the current K), K_i
          // from the rotation rows with the offset held.
          beta(3) = 0.5 * (U + D);
          std::vector<Eigen::Index> rot;
          for (Eigen::Index j = 0; j < n; ++j)
            if (!rows.is_static[static_cast<std::size_t>(j)]) rot.push_back(j);
          if (rot.size() < 3) break;
          Eigen::MatrixXd A(static_cast<Eigen::Index>(rot.size()), 3);
          Eigen::VectorXd z(static_cast<Eigen::Index>(rot.size()));
          for (std::size_t q = 0; q < rot.size(); ++q) {
            A.row(static_cast<Eigen::Index>(q)) =
                rows.input[static_cast<std::size_t>(rot[q])].transpose();
            z(static_cast<Eigen::Index>(q)) = y(rot[q]) - beta(3);
          }
          beta.head<3>() = A.colPivHouseholderQr().solve(z);
          // Covariance from the sensor noise: the offset from the pair means, K_i from the
          // rotation rows with the offset's uncertainty carried into them.
          const double var_o = 0.25 * (meanVar(up, i) + meanVar(down, i));
          Eigen::VectorXd w(static_cast<Eigen::Index>(rot.size()));
          for (std::size_t q = 0; q < rot.size(); ++q) {
            const double se = rows.reading_se[static_cast<std::size_t>(rot[q])][i];
            w(static_cast<Eigen::Index>(q)) = se > 0.0 ? 1.0 / (se * se) : 0.0;
          }
          const Eigen::Matrix3d N = A.transpose() * w.asDiagonal() * A;
          if (w.minCoeff() > 0.0 && N.determinant() != 0.0) {
            const Eigen::Matrix3d Ninv = N.inverse();
            const Eigen::Vector3d g = -Ninv * A.transpose() * w.asDiagonal() *
                                      Eigen::VectorXd::Ones(static_cast<Eigen::Index>(rot.size()));
            cov_pair.setZero();
            cov_pair.topLeftCorner<3, 3>() = Ninv + g * g.transpose() * var_o;
            cov_pair.block<3, 1>(0, 3) = g * var_o;
            cov_pair.block<1, 3>(3, 0) = (g * var_o).transpose();
            cov_pair(3, 3) = var_o;
            have_cov_pair = true;
          }
        }
      }
    } else {
      if (pairwise)
        notes->push_back(triad + " axis " + kAxis[static_cast<std::size_t>(i)] +
                         ": no axis-up/axis-down pair of positions, joint least squares "
                         "(table errors may leak into its scale and bias)");
      Eigen::JacobiSVD<Eigen::MatrixXd> svd0(X, Eigen::ComputeThinU | Eigen::ComputeThinV);
      svd0.setThreshold(1e-10);
      beta = svd0.solve(y);
    }
    // Joint estimator: covariance of the design scaled by the residual scatter. The pairwise
    // estimator replaces it with the noise propagation above.
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(X, Eigen::ComputeThinU | Eigen::ComputeThinV);
    svd.setThreshold(1e-10);
    const Eigen::VectorXd r = y - X * beta;
    ss += r.squaredNorm();
    const double dof = std::max<double>(1.0, static_cast<double>(n - svd.rank()));
    const double s2 = r.squaredNorm() / dof;
    Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
    const Eigen::VectorXd sv = svd.singularValues();
    for (Eigen::Index k = 0; k < sv.size(); ++k)
      if (sv(k) > 1e-10 * sv(0))
        cov += svd.matrixV().col(k) * svd.matrixV().col(k).transpose() / (sv(k) * sv(k));
    cov *= s2;
    if (have_cov_pair) cov = cov_pair;
    K.row(i) = beta.head<3>().transpose();
    o(i) = beta(3);
    const double s = beta(i);
    for (int c = 0; c < 3; ++c) {
      if (c == i) {
        report->setSigma(names[static_cast<std::size_t>(c)], std::sqrt(cov(c, c)));
      } else {
        mis[static_cast<std::size_t>(model::misalignmentAt(i, c))] =
            misEntry(i, c).sign * beta(c) / s;
        report->setSigma(names[static_cast<std::size_t>(c)], std::sqrt(cov(c, c)) / std::abs(s));
      }
    }
    report->setSigma(names[3], std::sqrt(cov(3, 3)) / std::abs(s));
    for (const NullDirection& d : ia.null_directions)
      notes->push_back(triad + " axis " + kAxis[static_cast<std::size_t>(i)] +
                       ": the positions cannot separate " + d.description);
    for (std::size_t k = 0; k < names.size(); ++k)
      if (!ia.observable[k]) report->setUnobservable(names[k]);
  }
  out->scale = K.diagonal();
  out->bias = -o.cwiseQuotient(out->scale);
  out->mis = misalignmentFrom(mis.data());
  *rms = n > 0 ? std::sqrt(ss / (3.0 * static_cast<double>(n))) : 0.0;
}

}  // namespace

DirectCalibrationResult calibrateDirect(const DirectCalibrationInput& in,
                                        const DirectCalibrationOptions& o) {
  DirectCalibrationResult res;
  std::string why;
  if (!o.IsValid(&why)) {
    res.reason = "options: " + why;
    return res;
  }
  if (in.imu.size() < 2) {
    res.reason = "recording has fewer than 2 IMU samples";
    return res;
  }
  if (in.table.empty()) {
    res.reason = "recording has no table samples";
    return res;
  }
  const RecordingCheck check = checkIncrements(in.imu, o.checks, "recording");
  if (!check.ok()) {
    res.reason = check.reason;
    return res;
  }
  // The table as the calibration takes it: nominal, or with the errors known beforehand.
  const TableModel nominal(in.geometry, o.known_table_errors);
  const double g = nav::siteGravity(in.site);
  const Vec3 up_g(0.0, 0.0, g);
  const Vec3 w_ie_L = o.use_earth_rate ? nav::earthRateL(in.site.latitude_rad) : Vec3::Zero();
  const TableKind kind = in.geometry.kind;
  const double dt0 = in.imu[1].t - in.imu[0].t;
  auto startOf = [&](std::size_t i) { return i == 0 ? in.imu[0].t - dt0 : in.imu[i - 1].t; };

  Rows acc, gyr;
  std::vector<Vec3> gyro_sample_sigma;        // per-sample gyro noise of each hold
  std::vector<std::size_t> rotation_samples;  // samples in each rotation row
  for (const Segment& seg : in.segments) {
    if (!seg.recording) continue;
    if (seg.kind == SegmentKind::kStatic) {
      const double a = seg.t0 + o.static_trim_s, b = seg.t1 - o.static_trim_s;
      if (b - a < o.min_static_s) {
        res.notes.push_back("static '" + seg.label + "' too short after trimming: skipped");
        continue;
      }
      Vec3 dv = Vec3::Zero(), dth = Vec3::Zero();
      double T = 0.0;
      std::size_t i0 = in.imu.size(), i1 = 0;
      for (std::size_t i = 0; i < in.imu.size(); ++i) {
        if (startOf(i) < a || in.imu[i].t > b) continue;
        dv += in.imu[i].dvel;
        dth += in.imu[i].dtheta;
        T += in.imu[i].t - startOf(i);
        i0 = std::min(i0, i);
        i1 = i;
      }
      if (T < o.min_static_s) {
        res.notes.push_back("static '" + seg.label + "' has too few IMU samples: skipped");
        continue;
      }
      // Mean encoder angles over the window.
      TableAngles m{0, 0, 0};
      int cnt = 0;
      for (const TableSample& ts : in.table)
        if (ts.t >= a && ts.t <= b) {
          m.outer += ts.angles.outer;
          m.middle += ts.angles.middle;
          m.inner += ts.angles.inner;
          ++cnt;
        }
      if (cnt == 0) {
        m = anglesAt(in.table, 0.5 * (a + b));
      } else {
        m.outer /= cnt;
        m.middle /= cnt;
        m.inner /= cnt;
      }
      const Mat3 C_BL = nominal.C_LB(m).transpose();
      // Per-sample scatter of the readings: the white-noise level of this hold.
      Vec3 va = Vec3::Zero(), vg = Vec3::Zero();
      const double ns = static_cast<double>(i1 - i0 + 1);
      for (std::size_t i = i0; i <= i1 && i0 < in.imu.size(); ++i) {
        const double dt = in.imu[i].t - startOf(i);
        va += (in.imu[i].dvel / dt - dv / T).cwiseAbs2();
        vg += (in.imu[i].dtheta / dt - dth / T).cwiseAbs2();
      }
      const Vec3 sa = (va / std::max(ns - 1.0, 1.0)).cwiseSqrt();
      const Vec3 sg = (vg / std::max(ns - 1.0, 1.0)).cwiseSqrt();
      gyro_sample_sigma.push_back(sg);
      acc.reading_se.push_back(sa / std::sqrt(ns));
      gyr.reading_se.push_back(sg / std::sqrt(ns));
      acc.input.push_back(C_BL * up_g);
      acc.reading.push_back(dv / T);
      acc.what.push_back(seg.label);
      acc.is_static.push_back(true);
      acc.up_B.push_back(C_BL.col(2));
      gyr.input.push_back(C_BL * w_ie_L);
      gyr.reading.push_back(dth / T);
      gyr.what.push_back(seg.label);
      gyr.is_static.push_back(true);
      gyr.up_B.push_back(C_BL.col(2));
      ++res.statics_used;
    } else if (seg.kind == SegmentKind::kRotate) {
      if (seg.axis < 0 || seg.axis >= axisCount(kind)) {
        res.notes.push_back("rotation '" + seg.label + "' names no table axis: skipped");
        continue;
      }
      std::size_t first = in.imu.size(), last = 0;
      for (std::size_t i = 0; i < in.imu.size(); ++i)
        if (in.imu[i].t > seg.t0 && startOf(i) < seg.t1) {
          first = std::min(first, i);
          last = i;
        }
      if (first >= in.imu.size()) {
        res.notes.push_back("rotation '" + seg.label + "' has no IMU samples: skipped");
        continue;
      }
      // The segment holds the whole motion, ramps included, so the table rests on [ta, t0]
      // and [t1, tb]: the angle turned is read from encoder samples taken at rest on either
      // side. Interpolating them linearly at ta and tb instead brackets the ramp's quadratic
      // start and end and loses up to (accel/2) * (encoder period)^2 per end.
      const double ta = startOf(first), tb = in.imu[last].t;
      const TableAngles a0 = restAngles(in.table, seg.t0, true);
      const TableAngles a1 = restAngles(in.table, seg.t1, false);
      const double phi = axisAngle(a1, kind, seg.axis) - axisAngle(a0, kind, seg.axis);
      if (std::abs(phi) < o.min_rotation_rad) {
        res.notes.push_back("rotation '" + seg.label +
                            "' turns less than min_rotation_rad: skipped");
        continue;
      }
      Vec3 dth = Vec3::Zero(), earth = Vec3::Zero();
      for (std::size_t i = first; i <= last; ++i) {
        dth += in.imu[i].dtheta;
        const double tm = 0.5 * (startOf(i) + in.imu[i].t);
        earth +=
            nominal.C_LB(anglesAt(in.table, tm)).transpose() * w_ie_L * (in.imu[i].t - startOf(i));
      }
      const double T = tb - ta;
      gyr.input.push_back((axisInBody(nominal, a0, seg.axis) * phi + earth) / T);
      gyr.reading.push_back(dth / T);
      gyr.reading_se.push_back(Vec3::Zero());  // set below from the holds' noise level
      rotation_samples.push_back(last - first + 1);
      gyr.what.push_back(seg.label);
      gyr.is_static.push_back(false);
      gyr.up_B.push_back(Vec3::Zero());
      ++res.rotations_used;
    }
  }
  if (res.statics_used < 4) {
    res.reason = "only " + std::to_string(res.statics_used) +
                 " usable static positions: need >= 4 (12 accelerometer unknowns, 4 per axis)";
    return res;
  }
  // A rotation row's mean rate carries the white gyro noise of its samples: the median
  // per-sample level of the holds (motion hides it inside the run itself), floored so that a
  // noise-free simulation keeps finite weights.
  {
    Vec3 level = Vec3::Constant(1e-12);
    for (int k = 0; k < 3; ++k) {
      std::vector<double> v;
      for (const Vec3& s : gyro_sample_sigma) v.push_back(s[k]);
      std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
      level[k] = std::max(level[k], v[v.size() / 2]);
    }
    std::size_t r = 0;
    for (std::size_t j = 0; j < gyr.reading.size(); ++j) {
      if (gyr.is_static[j]) {
        gyr.reading_se[j] = gyr.reading_se[j].cwiseMax(Vec3::Constant(1e-15));
        continue;
      }
      gyr.reading_se[j] = level / std::sqrt(static_cast<double>(rotation_samples[r++]));
    }
    for (Vec3& se : acc.reading_se) se = se.cwiseMax(Vec3::Constant(1e-15));
  }
  const bool pairwise = o.estimator == DirectEstimator::kAxisPairs;
  fitTriad(acc, TriadKind::kAccel, pairwise, "accel", &res.report.values.sensors.accel, &res.report,
           &res.notes, &res.accel_residual_rms);
  if (res.rotations_used == 0)
    res.notes.push_back("no rate runs: gyro scales and misalignments rest on the Earth rate alone");
  fitTriad(gyr, TriadKind::kGyro, pairwise && res.rotations_used >= 3, "gyro",
           &res.report.values.sensors.gyro, &res.report, &res.notes, &res.gyro_residual_rms);
  res.report.values.table_kind = kind;
  res.notes.push_back(
      "table errors are not estimated by direct calibration: they leak into the coefficients "
      "(mounting into both triads' misalignments, base tilt into the accelerometers')");
  res.ok = true;
  return res;
}

}  // namespace imubench::calib
