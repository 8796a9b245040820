#include "calib/direct_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <span>
#include <sstream>
#include <utility>

#include "calib/observability.h"
#include "calib/option_check.h"
#include "calib/static_detection.h"

namespace imubench::calib {

bool DirectCalibrationOptions::IsValid(std::string* why) const {
  if (!(static_trim_s >= 0.0)) return invalidOption(why, "static_trim_s must be >= 0");
  if (!(min_static_s > 0.0)) return invalidOption(why, "min_static_s must be > 0");
  if (!(min_rotation_rad > 0.0)) return invalidOption(why, "min_rotation_rad must be > 0");
  if (!(turn_tolerance_rad >= 0.0)) return invalidOption(why, "turn_tolerance_rad must be >= 0");
  if (!(accel_residual_floor > 0.0) || !(gyro_residual_floor > 0.0))
    return invalidOption(why, "the residual floors must be > 0");
  if (!segment_check.IsValid(why) || !quality.IsValid(why)) return false;
  return checks.IsValid(why);
}

namespace {

constexpr std::array<const char*, 3> kAxis = {"x", "y", "z"};

// Encoder angles at time t, linear between samples, held outside.
TableAngles anglesAt(std::span<const TableSample> table, double t) {
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
TableAngles restAngles(std::span<const TableSample> table, double t, bool before) {
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
  if (axis == 0) {
    st.outer.rate = 1.0;
  } else if (kind == TableKind::kThreeAxis && axis == 1) {
    st.middle.rate = 1.0;
  } else {
    st.inner.rate = 1.0;
  }
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

// Variance of the mean over the rows `idx` of axis i's reading (white sensor noise).
double meanVar(const Rows& rows, const std::vector<std::size_t>& idx, int i) {
  double v = 0.0;
  for (std::size_t j : idx) v += rows.reading_se[j][i] * rows.reading_se[j][i];
  return v / (static_cast<double>(idx.size()) * static_cast<double>(idx.size()));
}

// Inverse-variance weights of every row for axis i (1 where no noise level is known).
Eigen::VectorXd rowWeights(const Rows& rows, int i) {
  const Eigen::Index n = static_cast<Eigen::Index>(rows.input.size());
  Eigen::VectorXd w(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double se = rows.reading_se[static_cast<std::size_t>(j)][i];
    w(j) = se > 0.0 ? 1.0 / (se * se) : 1.0;
  }
  return w;
}

// One axis' data: the design X = [input | 1], the readings y of axis i, its up/down rows.
struct AxisData {
  const Rows& rows;
  const Eigen::MatrixXd& X;
  const Eigen::VectorXd& y;
  int i;
  std::vector<std::size_t> up, down;
};

// Layout of one axis' unknowns beta = (K_i0, K_i1, K_i2, o_i): the gain-row entries at the
// input column they multiply, the offset (-scale * bias) after them.
constexpr int kOffsetCol = 3;

// One axis' estimate: beta = (K_i, o_i) and, when the noise propagation gives it, its
// covariance.
struct AxisFit {
  Eigen::Vector4d beta = Eigen::Vector4d::Zero();
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
  bool have_cov = false;
};

// Mean over `idx` of axis i's reading with the input terms of beta removed (except column
// `skip`).
double pairMean(const AxisData& d, const std::vector<std::size_t>& idx, const Eigen::Vector4d& b,
                int skip) {
  double m = 0.0;
  for (std::size_t j : idx) {
    double v = d.y(static_cast<Eigen::Index>(j));
    for (int c = 0; c < 3; ++c)
      if (c != skip) v -= b(c) * d.rows.input[j][c];
    m += v;
  }
  return m / static_cast<double>(idx.size());
}

// Accelerometer axis: scale and offset from the axis-up/axis-down positions (a table error
// tilts the input there only to second order), the off-diagonal terms from every static
// position with them held; covariance from the sensor noise (the residual scatter also holds
// the table errors, which are a bias of the misalignments, not noise).
void accelPairStep(const AxisData& d, AxisFit* f) {
  const int i = d.i;
  const Eigen::Index n = d.X.rows();
  const double U = pairMean(d, d.up, f->beta, i), D = pairMean(d, d.down, f->beta, i);
  double gu = 0.0, gd = 0.0;
  for (std::size_t j : d.up) gu += d.rows.input[j][i] / static_cast<double>(d.up.size());
  for (std::size_t j : d.down) gd += d.rows.input[j][i] / static_cast<double>(d.down.size());
  f->beta(i) = (U - D) / (gu - gd);
  f->beta(kOffsetCol) = U - f->beta(i) * gu;
  Eigen::MatrixXd A(n, 2);
  Eigen::VectorXd z(n);
  const int c1 = (i + 1) % 3, c2 = (i + 2) % 3;
  for (Eigen::Index j = 0; j < n; ++j) {
    const Vec3& in = d.rows.input[static_cast<std::size_t>(j)];
    A(j, 0) = in[c1];
    A(j, 1) = in[c2];
    z(j) = d.y(j) - f->beta(kOffsetCol) - f->beta(i) * in[i];
  }
  const Eigen::Vector2d m2 = A.colPivHouseholderQr().solve(z);
  f->beta(c1) = m2(0);
  f->beta(c2) = m2(1);
  // U, D are means of the up/down rows; the off-diagonal fit adds its own noise and that of
  // (scale, offset).
  const double varU = meanVar(d.rows, d.up, i), varD = meanVar(d.rows, d.down, i);
  const double den = gu - gd;
  Eigen::Matrix2d J_so;  // d(scale, offset)/d(U, D)
  J_so << 1.0 / den, -1.0 / den, -gd / den, gu / den;
  const Eigen::Matrix2d cov_so = J_so * Eigen::Vector2d(varU, varD).asDiagonal() * J_so.transpose();
  const Eigen::VectorXd w = rowWeights(d.rows, i);
  const Eigen::Matrix2d Ninv = (A.transpose() * w.asDiagonal() * A).inverse();
  Eigen::MatrixXd B(n, 2);  // dz/d(scale, offset)
  for (Eigen::Index j = 0; j < n; ++j) {
    B(j, 0) = -d.rows.input[static_cast<std::size_t>(j)][i];
    B(j, 1) = -1.0;
  }
  const Eigen::Matrix2d G = Ninv * A.transpose() * w.asDiagonal() * B;
  const Eigen::Matrix2d cov_m = Ninv + G * cov_so * G.transpose();
  const Eigen::Matrix2d cov_m_so = G * cov_so;
  const int idx[4] = {i, kOffsetCol, c1, c2};
  Eigen::Matrix4d C = Eigen::Matrix4d::Zero();
  C.block<2, 2>(0, 0) = cov_so;
  C.block<2, 2>(2, 2) = cov_m;
  C.block<2, 2>(2, 0) = cov_m_so;
  C.block<2, 2>(0, 2) = cov_m_so.transpose();
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) f->cov(idx[a], idx[b]) = C(a, b);
  f->have_cov = true;
}

// Gyro axis: offset from the up/down pair (Earth-rate inputs removed with the current K),
// K_i from the rotation rows with the offset held; covariance from the sensor noise, the
// offset's uncertainty carried into K_i. False when there are fewer than 3 rotation rows.
bool gyroPairStep(const AxisData& d, AxisFit* f) {
  const int i = d.i;
  f->beta(kOffsetCol) = 0.5 * (pairMean(d, d.up, f->beta, -1) + pairMean(d, d.down, f->beta, -1));
  std::vector<Eigen::Index> rot;
  for (Eigen::Index j = 0; j < d.X.rows(); ++j)
    if (!d.rows.is_static[static_cast<std::size_t>(j)]) rot.push_back(j);
  if (rot.size() < 3) return false;
  const Eigen::Index m = static_cast<Eigen::Index>(rot.size());
  Eigen::MatrixXd A(m, 3);
  Eigen::VectorXd z(m), w(m);
  for (Eigen::Index q = 0; q < m; ++q) {
    const std::size_t j = static_cast<std::size_t>(rot[static_cast<std::size_t>(q)]);
    A.row(q) = d.rows.input[j].transpose();
    z(q) = d.y(static_cast<Eigen::Index>(j)) - f->beta(kOffsetCol);
    const double se = d.rows.reading_se[j][i];
    w(q) = se > 0.0 ? 1.0 / (se * se) : 0.0;
  }
  f->beta.head<3>() = A.colPivHouseholderQr().solve(z);
  const double var_o = 0.25 * (meanVar(d.rows, d.up, i) + meanVar(d.rows, d.down, i));
  const Eigen::Matrix3d N = A.transpose() * w.asDiagonal() * A;
  if (w.minCoeff() > 0.0 && N.determinant() != 0.0) {
    const Eigen::Matrix3d Ninv = N.inverse();
    const Eigen::Vector3d g = -Ninv * A.transpose() * w.asDiagonal() * Eigen::VectorXd::Ones(m);
    f->cov.setZero();
    f->cov.topLeftCorner<3, 3>() = Ninv + g * g.transpose() * var_o;
    f->cov.block<3, 1>(0, kOffsetCol) = g * var_o;
    f->cov.block<1, 3>(kOffsetCol, 0) = (g * var_o).transpose();
    f->cov(kOffsetCol, kOffsetCol) = var_o;
    f->have_cov = true;
  }
  return true;
}

// The seed's classic estimator for one axis (4 passes: each step uses the others' terms).
AxisFit fitAxisPairs(const AxisData& d, TriadKind kind) {
  AxisFit f;
  f.beta(d.i) = 1.0;
  for (int iter = 0; iter < 4; ++iter) {
    if (kind == TriadKind::kAccel) {
      accelPairStep(d, &f);
    } else if (!gyroPairStep(d, &f)) {
      break;
    }
  }
  return f;
}

// Covariance of the joint least squares: the design's, scaled by the residual scatter.
Eigen::Matrix4d jointCovariance(const Eigen::MatrixXd& X, const Eigen::VectorXd& r) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(X, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-10);
  const double dof = std::max<double>(1.0, static_cast<double>(X.rows() - svd.rank()));
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
  const Eigen::VectorXd sv = svd.singularValues();
  for (Eigen::Index k = 0; k < sv.size(); ++k) {
    if (sv(k) > 1e-10 * sv(0)) {
      cov += svd.matrixV().col(k) * svd.matrixV().col(k).transpose() / (sv(k) * sv(k));
    }
  }
  return cov * (r.squaredNorm() / dof);
}

// Names of K_i's entries: diagonal -> scale, off-diagonal -> misalignment (the model's
// kMisEntries: which entry of M, with which sign), o -> bias.
const model::MisalignmentEntry& misEntry(int row, int col) {
  return model::kMisEntries[static_cast<std::size_t>(model::misalignmentAt(row, col))];
}
std::vector<std::string> axisNames(const std::string& triad, int i) {
  std::vector<std::string> names;
  names.reserve(4);
  for (int c = 0; c < 3; ++c) {
    names.push_back(c == i ? triad + ".scale." + kAxis[static_cast<std::size_t>(i)]
                           : triad + ".misalignment." + misEntry(i, c).name);
  }
  names.push_back(triad + ".bias." + kAxis[static_cast<std::size_t>(i)]);
  return names;
}

// Per-axis least squares of reading_i = K_i . input + o_i; fills the triad, sigmas and flags,
// the RMS residual and each row's normalised squared residual (summed over the axes).
void fitTriad(const Rows& rows, TriadKind kind, bool pairwise, const std::string& triad,
              TriadModel* out, CoefficientReport* report, std::vector<std::string>* notes,
              double* rms, double residual_floor, std::vector<double>* row_ss,
              std::vector<std::string>* noise_only = nullptr) {
  const Eigen::Index n = static_cast<Eigen::Index>(rows.input.size());
  Eigen::MatrixXd X(n, 4);
  for (Eigen::Index j = 0; j < n; ++j) {
    X.block<1, 3>(j, 0) = rows.input[static_cast<std::size_t>(j)].transpose();
    X(j, 3) = 1.0;
  }
  double ss = 0.0;
  Mat3 K = Mat3::Identity();
  Vec3 o = Vec3::Zero();
  std::array<double, model::kMisCount> mis{};
  row_ss->assign(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < 3; ++i) {
    const std::vector<std::string> names = axisNames(triad, i);
    Eigen::VectorXd y(n);
    for (Eigen::Index j = 0; j < n; ++j) y(j) = rows.reading[static_cast<std::size_t>(j)][i];
    const InformationAnalysis ia = analyseInformation(X, names);
    AxisData d{rows, X, y, i, {}, {}};
    AxisFit f;
    if (pairwise && axisPairs(rows, i, &d.up, &d.down)) {
      f = fitAxisPairs(d, kind);
    } else {
      if (pairwise) {
        notes->push_back(triad + " axis " + kAxis[static_cast<std::size_t>(i)] +
                         ": no axis-up/axis-down pair of positions, joint least squares "
                         "(table errors may leak into its scale and bias)");
      }
      Eigen::JacobiSVD<Eigen::MatrixXd> svd0(X, Eigen::ComputeThinU | Eigen::ComputeThinV);
      svd0.setThreshold(1e-10);
      f.beta = svd0.solve(y);
    }
    const Eigen::Vector4d& beta = f.beta;
    const Eigen::VectorXd r = y - X * beta;
    ss += r.squaredNorm();
    for (Eigen::Index j = 0; j < n; ++j) {
      const double se = std::max(rows.reading_se[static_cast<std::size_t>(j)][i], residual_floor);
      (*row_ss)[static_cast<std::size_t>(j)] += r(j) * r(j) / (se * se);
    }
    // The pairwise estimator's noise propagation replaces the joint covariance.
    const Eigen::Matrix4d cov = f.have_cov ? f.cov : jointCovariance(X, r);
    if (f.have_cov && noise_only) noise_only->insert(noise_only->end(), names.begin(), names.end());
    K.row(i) = beta.head<3>().transpose();
    o(i) = beta(kOffsetCol);
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
    report->setSigma(names[kOffsetCol], std::sqrt(cov(kOffsetCol, kOffsetCol)) / std::abs(s));
    for (const NullDirection& nd : ia.null_directions) {
      notes->push_back(triad + " axis " + kAxis[static_cast<std::size_t>(i)] +
                       ": the positions cannot separate " + nd.description);
    }
    for (std::size_t k = 0; k < names.size(); ++k)
      if (!ia.observable[k]) report->setUnobservable(names[k]);
  }
  out->scale = K.diagonal();
  out->bias = -o.cwiseQuotient(out->scale);
  out->mis = misalignmentFrom(mis.data());
  *rms = n > 0 ? std::sqrt(ss / (3.0 * static_cast<double>(n))) : 0.0;
}

// Mean encoder angles over [a, b] (the nearest interpolated angles when no sample falls in).
TableAngles meanAngles(std::span<const TableSample> table, double a, double b) {
  TableAngles m{0, 0, 0};
  int cnt = 0;
  for (const TableSample& ts : table) {
    if (ts.t < a || ts.t > b) continue;
    m.outer += ts.angles.outer;
    m.middle += ts.angles.middle;
    m.inner += ts.angles.inner;
    ++cnt;
  }
  if (cnt == 0) return anglesAt(table, 0.5 * (a + b));
  return {m.outer / cnt, m.middle / cnt, m.inner / cnt};
}

// What every row of the fit is built from: the input, the table as taken, the site.
struct RowContext {
  const RecordingView& in;
  const DirectCalibrationOptions& o;
  TableModel table;  // nominal, or with the errors known beforehand
  Vec3 up_g;         // (0, 0, g) in L
  Vec3 w_ie_L;       // Earth rate in L (zero when not used)
  double dt0;        // first sample's interval
  double startOf(std::size_t i) const { return i == 0 ? in.imu[0].t - dt0 : in.imu[i - 1].t; }
  // The first sample whose interval starts at or after t (times increase: checkInput).
  std::size_t firstStartingFrom(double t) const {
    std::size_t lo = 0, hi = in.imu.size();
    while (lo < hi) {
      const std::size_t mid = lo + (hi - lo) / 2;
      if (startOf(mid) < t) {
        lo = mid + 1;
      } else {
        hi = mid;
      }
    }
    return lo;
  }
};

// All rows of both triads plus what the gyro rows' weights need.
struct DirectRows {
  Rows acc, gyr;
  std::vector<Vec3> gyro_sample_sigma;        // per-sample gyro noise of each hold
  std::vector<std::size_t> rotation_samples;  // samples in each rotation row
};

// One static segment -> an accelerometer row and a gyro row (false + note when unusable).
bool addStaticRow(const RowContext& c, const Segment& seg, DirectRows* rows,
                  std::vector<std::string>* notes) {
  const double a = seg.t0 + c.o.static_trim_s, b = seg.t1 - c.o.static_trim_s;
  if (b - a < c.o.min_static_s) {
    notes->push_back("static '" + seg.label + "' too short after trimming: skipped");
    return false;
  }
  Vec3 dv = Vec3::Zero(), dth = Vec3::Zero();
  double T = 0.0;
  std::size_t i0 = c.in.imu.size(), i1 = 0;
  for (std::size_t i = c.firstStartingFrom(a); i < c.in.imu.size() && c.in.imu[i].t <= b; ++i) {
    dv += c.in.imu[i].dvel;
    dth += c.in.imu[i].dtheta;
    T += c.in.imu[i].t - c.startOf(i);
    i0 = std::min(i0, i);
    i1 = i;
  }
  if (T < c.o.min_static_s) {
    notes->push_back("static '" + seg.label + "' has too few IMU samples: skipped");
    return false;
  }
  const Mat3 C_BL = c.table.C_LB(meanAngles(c.in.table, a, b)).transpose();
  // Per-sample scatter of the readings: the white-noise level of this hold (two-pass).
  Vec3 va = Vec3::Zero(), vg = Vec3::Zero();
  const double ns = static_cast<double>(i1 - i0 + 1);
  for (std::size_t i = i0; i <= i1; ++i) {
    const double dt = c.in.imu[i].t - c.startOf(i);
    va += (c.in.imu[i].dvel / dt - dv / T).cwiseAbs2();
    vg += (c.in.imu[i].dtheta / dt - dth / T).cwiseAbs2();
  }
  const Vec3 sa = (va / std::max(ns - 1.0, 1.0)).cwiseSqrt();
  const Vec3 sg = (vg / std::max(ns - 1.0, 1.0)).cwiseSqrt();
  rows->gyro_sample_sigma.push_back(sg);
  for (Rows* r : {&rows->acc, &rows->gyr}) {
    const bool accel = r == &rows->acc;
    r->reading_se.push_back((accel ? sa : sg) / std::sqrt(ns));
    r->input.push_back(C_BL * (accel ? c.up_g : c.w_ie_L));
    r->reading.push_back((accel ? dv : dth) / T);
    r->what.push_back(seg.label);
    r->is_static.push_back(true);
    r->up_B.push_back(C_BL.col(2));
  }
  return true;
}

// `a` with the angle of table axis `axis` set to `angle`.
TableAngles withAxisAngle(TableAngles a, TableKind kind, int axis, double angle) {
  if (axis == 0) {
    a.outer = angle;
  } else if (kind == TableKind::kThreeAxis && axis == 1) {
    a.middle = angle;
  } else {
    a.inner = angle;
  }
  return a;
}

// The Earth rate a turn about one table axis adds to the gyro readings of samples
// [first, last] (integrated, in B). The angle about the turning axis at each sample is placed
// by the gyros' own integral along that axis (`turned`, its total dth_B), scaled to the
// encoders' net turn `phi` from their rest angles `a0`: dense and on the IMU's clock. Encoder
// samples taken while turning are not used: their stamps carry the table's reply latency,
// and at 30 deg/s a stamp 0.4 s late turns the Earth rate's direction by 12 deg, which put
// 0.06-0.3 arcsec (2-4 sigma) into the gyro misalignments of the e2e runs and this test.
Vec3 earthRateDuringTurn(const RowContext& c, int axis, const TableAngles& a0, double phi,
                         const Vec3& axis_B, std::size_t first, std::size_t last, const Vec3& dth) {
  const TableKind kind = c.in.geometry.kind;
  const double start = axisAngle(a0, kind, axis);
  // The Earth rate along the turning axis is constant (the axis is fixed in L): taken out of
  // the gyros' integral, which then follows the table's angle (its scale cancels).
  const double w_along = axis_B.dot(c.table.C_LB(a0).transpose() * c.w_ie_L);
  const double T = c.in.imu[last].t - c.startOf(first);
  const double turned = axis_B.dot(dth) - w_along * T;
  Vec3 earth = Vec3::Zero();
  double so_far = 0.0;
  for (std::size_t i = first; i <= last; ++i) {
    const double step = axis_B.dot(c.in.imu[i].dtheta) - w_along * (c.in.imu[i].t - c.startOf(i));
    const double fraction = turned != 0.0 ? (so_far + 0.5 * step) / turned : 0.0;
    so_far += step;
    const TableAngles at = withAxisAngle(a0, kind, axis, start + fraction * phi);
    earth += c.table.C_LB(at).transpose() * c.w_ie_L * (c.in.imu[i].t - c.startOf(i));
  }
  return earth;
}

// One rotate segment -> a gyro row (false + note when unusable).
bool addRotationRow(const RowContext& c, const Segment& seg, DirectRows* rows,
                    std::vector<std::string>* notes) {
  const TableKind kind = c.in.geometry.kind;
  if (seg.axis < 0 || seg.axis >= axisCount(kind)) {
    notes->push_back("rotation '" + seg.label + "' names no table axis: skipped");
    return false;
  }
  std::size_t first = c.in.imu.size(), last = 0;
  // Samples ending after t0 and starting before t1: from the one before the first starting at
  // t0 or later (the previous one ends where it starts).
  const std::size_t from = c.firstStartingFrom(seg.t0);
  for (std::size_t i = from > 0 ? from - 1 : 0; i < c.in.imu.size() && c.startOf(i) < seg.t1; ++i) {
    if (c.in.imu[i].t <= seg.t0) continue;
    first = std::min(first, i);
    last = i;
  }
  if (first >= c.in.imu.size()) {
    notes->push_back("rotation '" + seg.label + "' has no IMU samples: skipped");
    return false;
  }
  // The segment holds the whole motion, ramps included, so the table rests on [ta, t0] and
  // [t1, tb]: the angle turned is read from encoder samples taken at rest on either side
  // (interpolating at ta and tb would bracket the ramps' quadratic start and end). Whole
  // turns come from the segment's unwrapped net angle (encoders wrap at 360 deg).
  const double ta = c.startOf(first), tb = c.in.imu[last].t;
  const TableAngles a0 = restAngles(c.in.table, seg.t0, true);
  const TableAngles a1 = restAngles(c.in.table, seg.t1, false);
  double phi = axisAngle(a1, kind, seg.axis) - axisAngle(a0, kind, seg.axis);
  if (seg.angle != 0.0 && std::abs(seg.angle - phi) > kPi) {
    phi += 2.0 * kPi * std::round((seg.angle - phi) / (2.0 * kPi));
  }
  if (std::abs(phi) < c.o.min_rotation_rad - c.o.turn_tolerance_rad) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.9f deg", phi / kDegToRad);
    notes->push_back("rotation '" + seg.label + "' turns " + buf +
                     ", less than min_rotation_rad: skipped");
    return false;
  }
  const Vec3 axis_B = axisInBody(c.table, a0, seg.axis);
  Vec3 dth = Vec3::Zero();
  for (std::size_t i = first; i <= last; ++i) dth += c.in.imu[i].dtheta;
  const Vec3 earth = earthRateDuringTurn(c, seg.axis, a0, phi, axis_B, first, last, dth);
  const double T = tb - ta;
  rows->gyr.input.push_back((axis_B * phi + earth) / T);
  rows->gyr.reading.push_back(dth / T);
  rows->gyr.reading_se.push_back(Vec3::Zero());  // set by setRowNoise from the holds
  rows->rotation_samples.push_back(last - first + 1);
  rows->gyr.what.push_back(seg.label);
  rows->gyr.is_static.push_back(false);
  rows->gyr.up_B.push_back(Vec3::Zero());
  return true;
}

// A rotation row's mean rate carries the white gyro noise of its samples: the median
// per-sample level of the holds (motion hides it inside the run itself), floored so that a
// noise-free recording keeps finite weights.
void setRowNoise(DirectRows* rows) {
  Vec3 level = Vec3::Constant(1e-12);
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    for (const Vec3& s : rows->gyro_sample_sigma) v.push_back(s[k]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    level[k] = std::max(level[k], v[v.size() / 2]);
  }
  std::size_t r = 0;
  Rows& g = rows->gyr;
  for (std::size_t j = 0; j < g.reading.size(); ++j) {
    if (g.is_static[j]) {
      g.reading_se[j] = g.reading_se[j].cwiseMax(Vec3::Constant(1e-15));
      continue;
    }
    g.reading_se[j] = level / std::sqrt(static_cast<double>(rows->rotation_samples[r++]));
  }
  for (Vec3& se : rows->acc.reading_se) se = se.cwiseMax(Vec3::Constant(1e-15));
}

// The largest normalised residuals by row, "static 'h3' accel: 35 sigma", largest first.
void largestResiduals(const Rows& rows, const std::vector<double>& row_ss, const char* triad,
                      std::vector<std::pair<double, std::string>>* out) {
  for (std::size_t j = 0; j < row_ss.size() && j < rows.what.size(); ++j) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%s '%s' %s: %.1f sigma",
                  rows.is_static[j] ? "static" : "rotation", rows.what[j].c_str(), triad,
                  std::sqrt(row_ss[j] / 3.0));
    out->push_back({row_ss[j], buf});
  }
}

// Fit quality of the result: residuals against the noise, determined and plausible values.
// The misalignment sigmas propagated from the sensor noise alone (noise_only: their names)
// scaled by max(1, their triad's normalised RMS). Scales and biases keep theirs: the axis
// pairs' up/down differences cancel a tilt of the input to first order (the seed's finding),
// so the misfit a table error leaves is in the misalignment rows, and scaling the scales'
// and biases' sigmas by it overstated them about twofold on a 40" tilted table
// (DirectPlans.ScaleAndBiasSigmasAreHonestOnATiltedTable).
void scaleNoiseSigmas(const std::vector<std::string>& noise_only, DirectCalibrationResult* res) {
  res->accel_sigma_factor = std::max(1.0, res->accel_normalised_rms);
  res->gyro_sigma_factor = std::max(1.0, res->gyro_normalised_rms);
  for (const std::string& name : noise_only) {
    if (name.find(".misalignment.") == std::string::npos) continue;
    Uncertainty& u = res->report.uncertainty[name];
    if (!u.sigma) continue;
    *u.sigma *= name.rfind("accel.", 0) == 0 ? res->accel_sigma_factor : res->gyro_sigma_factor;
  }
}

void judgeDirect(const DirectRows& rows, const std::vector<double>& acc_ss,
                 const std::vector<double>& gyr_ss, const std::vector<std::string>& noise_only,
                 const DirectCalibrationOptions& o, DirectCalibrationResult* res) {
  double ss = 0.0;
  for (double v : acc_ss) ss += v;
  for (double v : gyr_ss) ss += v;
  const double nres = 3.0 * static_cast<double>(acc_ss.size() + gyr_ss.size());
  res->normalised_residual_rms = std::sqrt(ss / std::max(1.0, nres - 24.0));
  // Per triad: its rows' sum of squares over their degrees of freedom (12 unknowns each).
  auto triadRms = [](const std::vector<double>& triad_ss) {
    double sum = 0.0;
    for (double v : triad_ss) sum += v;
    return std::sqrt(sum / std::max(1.0, 3.0 * static_cast<double>(triad_ss.size()) - 12.0));
  };
  res->accel_normalised_rms = triadRms(acc_ss);
  res->gyro_normalised_rms = triadRms(gyr_ss);
  scaleNoiseSigmas(noise_only, res);
  std::vector<std::string> reasons;
  if (res->normalised_residual_rms > o.quality.max_normalised_rms) {
    char buf[200];
    std::snprintf(buf, sizeof(buf),
                  "normalised residual RMS %.3g (limit %.3g): the model with the table as taken "
                  "does not fit the data (table errors? give them with --table-errors, or "
                  "record navigation runs for the pipeline)",
                  res->normalised_residual_rms, o.quality.max_normalised_rms);
    reasons.push_back(buf);
  }
  const bool misfit = res->normalised_residual_rms > o.quality.max_normalised_rms;
  if (res->rotations_used == 0) {
    reasons.push_back(
        "no usable rate run: the gyro scales and misalignments rest on the Earth "
        "rate alone");
  }
  judgeCoefficients(res->report, o.quality, &reasons);
  std::vector<std::pair<double, std::string>> worst;
  largestResiduals(rows.acc, acc_ss, "accel", &worst);
  largestResiduals(rows.gyr, gyr_ss, "gyro", &worst);
  std::sort(worst.begin(), worst.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> largest;
  for (std::size_t k = 0; k < worst.size() && k < 3; ++k) largest.push_back(worst[k].second);
  res->status = fitStatusFrom(std::move(reasons), std::move(largest));
  res->status.misfit = misfit;
}

// Checks of the options and the recording; "" when usable.
std::string checkInput(const RecordingView& in, const DirectCalibrationOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) return "options: " + why;
  if (in.imu.size() < 2) return "recording has fewer than 2 IMU samples";
  if (in.table.empty()) return "recording has no table samples";
  const RecordingCheck check = checkIncrements(in.imu, o.checks, "recording", in.segments);
  return check.ok ? "" : check.message;
}

// Every usable static and rate run of the recording as rows (spans: each gyro row's segment
// span, in row order); counts and notes into res.
void collectRows(const RecordingView& in, const DirectCalibrationOptions& o, DirectRows* rows,
                 std::vector<std::pair<double, double>>* spans, DirectCalibrationResult* res) {
  const RowContext c{in,
                     o,
                     TableModel(in.geometry, o.known_table_errors),
                     Vec3(0.0, 0.0, nav::siteGravity(in.site)),
                     o.use_earth_rate ? nav::earthRateL(in.site.latitude_rad) : Vec3::Zero(),
                     in.imu[1].t - in.imu[0].t};
  // Holds split into settle + hold are one hold; segments contradicting the encoders named.
  const SegmentCheckResult segs =
      checkSegments(in.geometry.kind, in.table, in.segments, o.segment_check);
  res->notes = segs.notes;
  for (const Segment& seg : segs.segments) {
    if (!seg.recording) continue;
    if (seg.kind == SegmentKind::kStatic && addStaticRow(c, seg, rows, &res->notes)) {
      ++res->statics_used;
      spans->emplace_back(seg.t0, seg.t1);
    } else if (seg.kind == SegmentKind::kRotate && addRotationRow(c, seg, rows, &res->notes)) {
      ++res->rotations_used;
      spans->emplace_back(seg.t0, seg.t1);
    }
  }
}

}  // namespace

DirectCalibrationResult calibrateDirect(const RecordingView& in,
                                        const DirectCalibrationOptions& o) {
  DirectCalibrationResult res;
  if (std::string why = checkInput(in, o); !why.empty()) {
    res.status = FitStatus::Failed(std::move(why));
    return res;
  }
  DirectRows rows;
  std::vector<std::pair<double, double>> spans;
  collectRows(in, o, &rows, &spans, &res);
  if (res.statics_used < 4) {
    res.status = FitStatus::Failed(
        "only " + std::to_string(res.statics_used) +
        " usable static positions: need >= 4 (12 accelerometer unknowns, 4 per axis)");
    return res;
  }
  setRowNoise(&rows);
  const bool pairwise = o.estimator == DirectEstimator::kAxisPairs;
  std::vector<double> acc_ss, gyr_ss;
  std::vector<std::string> noise_only;
  fitTriad(rows.acc, TriadKind::kAccel, pairwise, "accel", &res.report.values.sensors.accel,
           &res.report, &res.notes, &res.accel_residual_rms, o.accel_residual_floor, &acc_ss,
           &noise_only);
  if (res.rotations_used == 0)
    res.notes.push_back("no rate runs: gyro scales and misalignments rest on the Earth rate alone");
  fitTriad(rows.gyr, TriadKind::kGyro, pairwise && res.rotations_used >= 3, "gyro",
           &res.report.values.sensors.gyro, &res.report, &res.notes, &res.gyro_residual_rms,
           o.gyro_residual_floor, &gyr_ss, &noise_only);
  res.report.values.table_kind = in.geometry.kind;
  // The table the rows were formed with: nominal, or the known errors (held, not estimated),
  // so the coefficients say which table they belong to.
  res.report.values.table = o.known_table_errors;
  const auto kb = axesBlock(o.known_table_errors);
  const auto kd = deviceBlock(o.known_table_errors);
  const bool known = std::any_of(kb.begin(), kb.end(), [](double v) { return v != 0.0; }) ||
                     std::any_of(kd.begin(), kd.end(), [](double v) { return v != 0.0; });
  res.notes.push_back(
      known ? "table errors are taken as known (given), not estimated by direct calibration"
            : "table errors are not estimated by direct calibration: they leak into the "
              "coefficients (mounting into both triads' misalignments, base tilt into the "
              "accelerometers')");
  judgeDirect(rows, acc_ss, gyr_ss, noise_only, o, &res);
  return res;
}

namespace {

// rows without row j.
Rows withoutRow(const Rows& r, std::size_t j) {
  Rows out = r;
  const auto at = [j](auto& v) { v.erase(v.begin() + static_cast<std::ptrdiff_t>(j)); };
  at(out.input);
  at(out.reading);
  at(out.reading_se);
  at(out.what);
  at(out.is_static);
  if (j < out.up_B.size()) at(out.up_B);
  return out;
}

// Both triads fitted on the rows (as calibrateDirect does), the values of the names.
std::map<std::string, double> refitValues(const DirectRows& rows, const DirectCalibrationOptions& o,
                                          int rotations, const std::vector<std::string>& names) {
  CoefficientReport rep;
  std::vector<std::string> notes;
  std::vector<double> ss;
  double rms = 0.0;
  const bool pairwise = o.estimator == DirectEstimator::kAxisPairs;
  fitTriad(rows.acc, TriadKind::kAccel, pairwise, "accel", &rep.values.sensors.accel, &rep, &notes,
           &rms, o.accel_residual_floor, &ss);
  fitTriad(rows.gyr, TriadKind::kGyro, pairwise && rotations >= 3, "gyro", &rep.values.sensors.gyro,
           &rep, &notes, &rms, o.gyro_residual_floor, &ss);
  std::map<std::string, double> out;
  for (const std::string& n : names) {
    const auto it = rep.uncertainty.find(n);
    if (it != rep.uncertainty.end() && !it->second.observable) continue;
    if (const std::optional<double> v = flatValue(rep.values, n)) out[n] = *v;
  }
  return out;
}

}  // namespace

SigmaCheck jackknifeDirect(const RecordingView& in, const DirectCalibrationOptions& o,
                           const DirectCalibrationResult& full, const SigmaCheckOptions& check) {
  SigmaCheck c;
  DirectCalibrationResult counts;
  DirectRows rows;
  std::vector<std::pair<double, double>> spans;
  if (!checkInput(in, o).empty() || !full.status.HasResult()) {
    c.why_not = "no direct calibration to check";
    return c;
  }
  collectRows(in, o, &rows, &spans, &counts);
  setRowNoise(&rows);
  const std::size_t n = rows.gyr.reading.size();
  if (static_cast<int>(n) < check.min_resamples) {
    c.why_not = std::to_string(counts.statics_used) + " static positions and " +
                std::to_string(counts.rotations_used) + " rate runs: fewer than the " +
                std::to_string(check.min_resamples) + " a leave-one-out estimate needs";
    return c;
  }
  std::map<std::string, double> printed;
  std::vector<std::string> names;
  for (const auto& [name, u] : full.report.uncertainty) {
    if (!u.observable || !u.sigma) continue;
    printed[name] = *u.sigma;
    names.push_back(name);
  }
  std::vector<std::map<std::string, double>> estimates;
  std::size_t s = 0;  // static rows: the same index in both triads' rows
  for (std::size_t j = 0; j < n; ++j) {
    DirectRows r = rows;
    const bool is_static = rows.gyr.is_static[j];
    r.gyr = withoutRow(rows.gyr, j);
    if (is_static) r.acc = withoutRow(rows.acc, s++);
    estimates.push_back(refitValues(r, o, counts.rotations_used - (is_static ? 0 : 1), names));
  }
  c = compareSigmas(printed, jackknifeSigmas(estimates), check);
  c.resamples = static_cast<int>(estimates.size());
  c.method = "jackknife: each of " + std::to_string(counts.statics_used) +
             " static positions and " + std::to_string(counts.rotations_used) +
             " rate runs left out once";
  return c;
}

DirectObservations directObservations(const RecordingView& in, const DirectCalibrationOptions& o) {
  DirectObservations out;
  if (std::string why = checkInput(in, o); !why.empty()) {
    out.status = Status::Error(std::move(why));
    return out;
  }
  DirectCalibrationResult counts;
  DirectRows rows;
  std::vector<std::pair<double, double>> spans;
  collectRows(in, o, &rows, &spans, &counts);
  out.notes = counts.notes;
  if (counts.statics_used < 4) {
    out.status =
        Status::Error("only " + std::to_string(counts.statics_used) + " usable static positions");
    return out;
  }
  setRowNoise(&rows);
  std::size_t s = 0;  // static rows: the same index in both triads' rows
  for (std::size_t j = 0; j < rows.gyr.reading.size(); ++j) {
    const bool is_static = rows.gyr.is_static[j];
    for (const bool accel : {true, false}) {
      if (accel && !is_static) continue;
      const Rows& r = accel ? rows.acc : rows.gyr;
      const std::size_t k = accel ? s : j;
      out.rows.push_back({accel, !is_static, r.input[k], r.reading[k], r.reading_se[k],
                          spans[j].first, spans[j].second, r.what[k]});
    }
    if (is_static) ++s;
  }
  out.status = Status::Ok();
  return out;
}

DirectCalibrationResult calibrateDirect(const DirectCalibrationInput& in,
                                        const DirectCalibrationOptions& o) {
  return calibrateDirect(viewOf(in), o);
}

DirectObservations directObservations(const DirectCalibrationInput& in,
                                      const DirectCalibrationOptions& o) {
  return directObservations(viewOf(in), o);
}

}  // namespace imubench::calib
