#include "io/coeff_export.h"

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/model/sensor_equation.h"

namespace imubench::io {
namespace {

using calib::TriadModel;
namespace model = calib::model;

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

std::string vec(const Vec3& v) {
  return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
}

// ---- matrix factorisations: A = T Q, T triangular with a positive diagonal, Q a rotation --

// A = L Q (L lower): A^T = Q' R' (Householder QR), so A = R'^T Q'^T.
void lowerRotation(const Mat3& A, Mat3* L, Mat3* Q) {
  Eigen::HouseholderQR<Mat3> qr(A.transpose());
  Mat3 Qp = qr.householderQ();
  Mat3 Rp = qr.matrixQR().triangularView<Eigen::Upper>();
  const Mat3 D = Rp.diagonal().array().sign().matrix().asDiagonal();
  Qp = Qp * D;
  Rp = D * Rp;
  *L = Rp.transpose();
  *Q = Qp.transpose();
}

// A = U Q (U upper): with P the exchange matrix, P A P = L' Q' (lower) gives U = P L' P,
// Q = P Q' P.
void upperRotation(const Mat3& A, Mat3* U, Mat3* Q) {
  Mat3 P = Mat3::Zero();
  P(0, 2) = P(1, 1) = P(2, 0) = 1.0;
  Mat3 L, Qp;
  lowerRotation(P * A * P, &L, &Qp);
  *U = P * L * P;
  *Q = P * Qp * P;
}

// Reading-side matrix of a triad: reading = A u - s.b, A = diag(s) M.
Mat3 readingMatrix(const TriadModel& t) {
  return t.scale.asDiagonal() * t.M();
}
// The bias term of the compensation, u = G reading + h: h = M^-1 b.
Vec3 compensationBias(const TriadModel& t) {
  return t.M().inverse() * t.bias;
}

std::string yamlMatrix(const std::string& key, const Mat3& m) {
  std::string s = "  " + key + ":\n";
  for (int r = 0; r < 3; ++r)
    s += "    - [" + num(m(r, 0)) + ", " + num(m(r, 1)) + ", " + num(m(r, 2)) + "]\n";
  return s;
}

std::string noiseLines(const std::optional<NoiseEstimate>& n, bool* ok) {
  *ok = n.has_value();
  if (!n) return "";
  auto mx = [](const std::array<double, 3>& a) { return std::max({a[0], a[1], a[2]}); };
  std::string s;
  s += "  # Noise: " + n->source + " (" + num(n->static_s) +
       " s static). Kalibr's continuous-time convention: density sigma_c (white noise, "
       "discrete sigma_d = sigma_c / sqrt(dt)), random walk sigma_b (bias diffusion, discrete "
       "sigma_bd = sigma_b sqrt(dt)); the largest axis is written (one value per triad).\n";
  if (n->accel.random_walk_bound || n->gyro.random_walk_bound)
    s += "  # The random walks are UPPER BOUNDS: the holds are too short to show the +1/2 slope "
         "of the Allan deviation.\n";
  s += "  accelerometer_noise_density: " + num(mx(n->accel.density)) + "  # m/s^2/sqrt(Hz)\n";
  s += "  accelerometer_random_walk: " + num(mx(n->accel.random_walk)) + "  # m/s^3/sqrt(Hz)\n";
  s += "  gyroscope_noise_density: " + num(mx(n->gyro.density)) + "  # rad/s/sqrt(Hz)\n";
  s += "  gyroscope_random_walk: " + num(mx(n->gyro.random_walk)) + "  # rad/s^2/sqrt(Hz)\n";
  s += "  update_rate: " + num(n->rate_hz) + "\n";
  return s;
}

// Kalibr ("kalibr" model: IMU frame = gyro frame, lower-triangular Dw, Da, R_IMUtoACC) and
// OpenVINS ("rpng" model: IMU frame = accel frame, upper-triangular, R_IMUtoGYRO).
ExportResult chainYaml(const ExportInput& in, bool kalibr) {
  ExportResult r;
  const Mat3 Ag = readingMatrix(in.sensors.gyro), Aa = readingMatrix(in.sensors.accel);
  Mat3 Tw, Ta, R_IMUtoGYRO = Mat3::Identity(), R_IMUtoACC = Mat3::Identity(), Q;
  if (kalibr) {
    lowerRotation(Ag, &Tw, &Q);  // IMU frame I = Q B
    lowerRotation(Aa * Q.transpose(), &Ta, &R_IMUtoACC);
  } else {
    upperRotation(Aa, &Ta, &Q);
    upperRotation(Ag * Q.transpose(), &Tw, &R_IMUtoGYRO);
  }
  const Mat3 Tg = in.gyro_g_sens ? Mat3(Ag * *in.gyro_g_sens * Q.transpose()) : Mat3(Mat3::Zero());
  const Vec3 hg = Q * compensationBias(in.sensors.gyro),
             ha = Q * compensationBias(in.sensors.accel);
  r.dropped.push_back(
      "gyro bias (the chain file has no bias; the filter estimates it from zero): "
      "residual " +
      vec(hg) + " rad/s in the IMU frame until estimated");
  r.dropped.push_back("accelerometer bias: residual " + vec(ha) + " m/s^2 in the IMU frame");
  if (in.thermal)
    r.dropped.push_back("the thermal model (--thermal): the chain file has constant intrinsics");
  bool noise = false;
  const std::string nl = noiseLines(in.noise, &noise);
  if (!noise) {
    r.status = Status::Error(
        "the coefficient file has no noise densities: give --recording DIR (the calibration "
        "recording; its static holds' Allan deviation gives them)");
    return r;
  }
  std::ostringstream s;
  s << "%YAML:1.0\n# imubench export-coeffs --to " << (kalibr ? "kalibr" : "openvins") << " from "
    << in.source << "\n"
    << "# Measurement model (OpenVINS propagation_analytical, model \""
    << (kalibr ? "kalibr" : "rpng")
    << "\"): w_m = Tw R_IMUtoGYRO w_I + Tg a_I + b_g, a_m = Ta R_IMUtoACC a_I + b_a;\n"
    << "# compensation: a_I = R_IMUtoACC^T Da (a_m - b_a), w_I = R_IMUtoGYRO^T Dw (w_m - Tg a_I - "
       "b_g), Dw = Tw^-1, Da = Ta^-1.\n"
    << "# "
    << (kalibr ? "Tw, Ta lower triangular, IMU frame = gyro frame (R_IMUtoGYRO = I)"
               : "Tw, Ta upper triangular, IMU frame = accel frame (R_IMUtoACC = I)")
    << ". The IMU frame I = imubench_R_BtoIMU * B (B: imubench's instrument frame).\n";
  for (const std::string& d : r.dropped) s << "# DROPPED: " << d << "\n";
  s << "imu0:\n  T_i_b:\n    - [1.0, 0.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0, 0.0]\n"
    << "    - [0.0, 0.0, 1.0, 0.0]\n    - [0.0, 0.0, 0.0, 1.0]\n"
    << nl << "  rostopic: /imu0\n  time_offset: 0.0\n  model: \"" << (kalibr ? "kalibr" : "rpng")
    << "\"\n"
    << yamlMatrix("Tw", Tw) << yamlMatrix("R_IMUtoGYRO", R_IMUtoGYRO) << yamlMatrix("Ta", Ta)
    << yamlMatrix("R_IMUtoACC", R_IMUtoACC) << yamlMatrix("Tg", Tg)
    << yamlMatrix("imubench_R_BtoIMU", Q);
  r.text = s.str();
  r.status = Status::Ok();
  return r;
}

// ---- PX4 and ArduPilot: per-axis offset (reading units) and accel scale -----------------

struct AxisFit {
  std::array<double, 4> c{};  // offset(T) = c0 + c1 x + c2 x^2 + c3 x^3, x = T - x_ref
  double fit_residual = 0.0;  // max |offset - fit| over the range, reading units
};

// The zero-input reading r0(T) = -s(T) b(T) of one axis over [tmin, tmax], fitted by a cubic
// in T - x_ref (least squares on 201 points).
AxisFit fitOffset(const ThermalFile& tf, const model::ThermalTriad& triad, int axis, double x_ref) {
  const auto& c = tf.coefficients;
  const int n = 201;
  Eigen::MatrixXd A(n, 4);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    const double T = c.t_min_c + (c.t_max_c - c.t_min_c) * i / (n - 1.0);
    const double s = model::thermalValue(triad[model::kScale + axis], T - c.t_ref_c, 0.0);
    const double b = model::thermalValue(triad[model::kBias + axis], T - c.t_ref_c, 0.0);
    y(i) = -s * b;
    for (int k = 0; k < 4; ++k) A(i, k) = std::pow(T - x_ref, k);
  }
  const Eigen::Vector4d p = A.colPivHouseholderQr().solve(y);
  AxisFit f;
  for (int k = 0; k < 4; ++k) f.c[k] = p(k);
  f.fit_residual = (A * p - y).cwiseAbs().maxCoeff();
  return f;
}

// What the per-axis targets drop from a thermal model: scale change over the range,
// misalignments, dT/dt terms, the cubic fit's residual.
// What the per-axis targets drop from a thermal model (maxima over 51 temperatures of the
// range): the accelerometer scale's change from its value at ref_c (has_scale: the target
// holds one constant scale) or the whole gyro scale (no gyro scale parameter), the
// misalignments, the dT/dt terms, the cubic fit's residual.
void thermalDropped(const ThermalFile& tf, const char* name, const model::ThermalTriad& triad,
                    double ref_c, bool has_scale, const std::array<AxisFit, 3>& fits,
                    std::vector<std::string>* dropped) {
  const auto& c = tf.coefficients;
  double ds = 0.0, mis = 0.0, h = 0.0, fit = 0.0;
  for (int i = 0; i <= 50; ++i) {
    const double dT = c.t_min_c + (c.t_max_c - c.t_min_c) * i / 50.0 - c.t_ref_c;
    for (int a = 0; a < 3; ++a) {
      const auto& sc = triad[model::kScale + a];
      const double s_ref = has_scale ? model::thermalValue(sc, ref_c - c.t_ref_c, 0.0) : 1.0;
      ds = std::max(ds, std::abs(model::thermalValue(sc, dT, 0.0) / s_ref - 1.0));
    }
    for (int k = model::kMis; k < model::kTriadSize; ++k)
      mis =
          std::max(mis, std::abs(model::thermalValue(triad[static_cast<std::size_t>(k)], dT, 0.0)));
  }
  for (int a = 0; a < 3; ++a) fit = std::max(fit, fits[a].fit_residual);
  for (const auto& p : triad)
    if (p.hysteresis) h = std::max(h, std::abs(p.dTdt));
  dropped->push_back(std::string(name) +
                     (has_scale ? " scale change over the range (one constant scale): up to "
                                : " scale (no gyro scale parameter): up to ") +
                     num(ds) + " of the input (relative)");
  dropped->push_back(std::string(name) + " misalignments: up to " + num(mis) +
                     " rad, residual up to that fraction of the input on the other axes");
  if (h > 0.0)
    dropped->push_back(std::string(name) + " hysteresis (dT/dt term): " + num(h) +
                       " per degC/s times the temperature rate");
  dropped->push_back(std::string(name) + " cubic fit of the offset: max residual " + num(fit) +
                     " (reading units) over the range");
}

void constantDropped(const calib::SensorModel& s, bool gyro_scale,
                     std::vector<std::string>* dropped) {
  auto misMax = [](const TriadModel& t) {
    return (t.M() - Mat3::Identity()).cwiseAbs().maxCoeff();
  };
  dropped->push_back("accelerometer misalignments (max " + num(misMax(s.accel)) +
                     " rad): residual up to that times the specific force on the other axes "
                     "(at 1 g: " +
                     num(misMax(s.accel) * 9.81) + " m/s^2)");
  dropped->push_back("gyro misalignments (max " + num(misMax(s.gyro)) +
                     " rad): residual up to that times the rate on the other axes");
  if (!gyro_scale)
    dropped->push_back("gyro scale " + vec(s.gyro.scale) +
                       " (no gyro scale parameter): residual (1 - s) times the rate per axis");
}

struct ParamWriter {
  std::ostringstream s;
  bool qgc = false;  // PX4/QGroundControl "1 1 NAME VALUE TYPE" lines; else ArduPilot NAME,VALUE
  void f(const std::string& name, double v) {
    if (qgc)
      s << "1\t1\t" << name << "\t" << num(v) << "\t9\n";
    else
      s << name << "," << num(v) << "\n";
  }
  void i(const std::string& name, int v) {
    if (qgc)
      s << "1\t1\t" << name << "\t" << v << "\t6\n";
    else
      s << name << "," << v << "\n";
  }
};

const char* kAxes = "XYZ";

ExportResult px4(const ExportInput& in) {
  ExportResult r;
  ParamWriter w;
  w.qgc = true;
  const auto& sa = in.sensors.accel;
  const auto& sg = in.sensors.gyro;
  std::array<AxisFit, 3> fa{}, fg{};
  Vec3 scale_a = sa.scale;
  if (in.thermal) {
    const ThermalFile& tf = *in.thermal;
    const double tref = tf.coefficients.t_ref_c;
    for (int a = 0; a < 3; ++a) {
      fa[a] = fitOffset(tf, tf.coefficients.accel, a, tref);
      fg[a] = fitOffset(tf, tf.coefficients.gyro, a, tref);
      scale_a[a] = model::thermalValue(tf.coefficients.accel[model::kScale + a], 0.0, 0.0);
    }
    thermalDropped(tf, "accelerometer", tf.coefficients.accel, tref, true, fa, &r.dropped);
    thermalDropped(tf, "gyro", tf.coefficients.gyro, tref, false, fg, &r.dropped);
  } else {
    constantDropped(in.sensors, false, &r.dropped);
  }
  for (int a = 0; a < 3; ++a) {
    const std::string ax(1, kAxes[a]);
    // Constant offsets; with a thermal model they are in TC_*_X0 and these are zero (PX4
    // subtracts both: a non-zero offset here would be applied twice).
    w.f("CAL_ACC0_" + ax + "OFF", in.thermal ? 0.0 : -sa.scale[a] * sa.bias[a]);
    w.f("CAL_ACC0_" + ax + "SCALE", 1.0 / scale_a[a]);
    w.f("CAL_GYRO0_" + ax + "OFF", in.thermal ? 0.0 : -sg.scale[a] * sg.bias[a]);
  }
  if (in.thermal) {
    const auto& c = in.thermal->coefficients;
    for (const char* p : {"TC_A", "TC_G"}) {
      const std::string b = std::string(p) + "0_";
      w.i(std::string(p) + "_ENABLE", 1);
      w.f(b + "TREF", c.t_ref_c);
      w.f(b + "TMIN", c.t_min_c);
      w.f(b + "TMAX", c.t_max_c);
      const auto& fits = p[3] == 'A' ? fa : fg;
      for (int k = 0; k < 4; ++k)
        for (int a = 0; a < 3; ++a)
          w.f(b + "X" + std::to_string(k) + "_" + std::to_string(a), fits[a].c[k]);
    }
  }
  std::ostringstream h;
  h << "# imubench export-coeffs --to px4 from " << in.source << "\n"
    << "# PX4 applies accel = R ((raw - thermal_offset - CAL_ACC0_*OFF) .* CAL_ACC0_*SCALE), gyro "
       "= R (raw - thermal_offset - CAL_GYRO0_*OFF)\n"
    << "# thermal_offset = X0 + X1 dT + X2 dT^2 + X3 dT^3, dT = clamp(T, TMIN, TMAX) - TREF "
       "(TC_A0_*, TC_G0_*); SI units (m/s^2, rad/s).\n"
    << "# Set TC_A0_ID / TC_G0_ID to the sensor's CAL_ACC0_ID / CAL_GYRO0_ID before loading.\n";
  for (const std::string& d : r.dropped) h << "# DROPPED: " << d << "\n";
  h << "# Vehicle-Id\tComponent-Id\tName\tValue\tType\n";
  r.text = h.str() + w.s.str();
  r.status = Status::Ok();
  return r;
}

constexpr double kArduTempReference = 35.0;  // AP_InertialSensor_tempcal.cpp TEMP_REFERENCE

ExportResult ardupilot(const ExportInput& in) {
  ExportResult r;
  ParamWriter w;
  const auto& sa = in.sensors.accel;
  const auto& sg = in.sensors.gyro;
  if (!in.thermal) {
    constantDropped(in.sensors, false, &r.dropped);
    for (int a = 0; a < 3; ++a) {
      const std::string ax(1, kAxes[a]);
      w.f("INS_ACCOFFS_" + ax, -sa.scale[a] * sa.bias[a]);
      w.f("INS_ACCSCAL_" + ax, 1.0 / sa.scale[a]);
      w.f("INS_GYROFFS_" + ax, -sg.scale[a] * sg.bias[a]);
    }
  } else {
    const ThermalFile& tf = *in.thermal;
    const auto& c = tf.coefficients;
    const double caltemp = std::clamp(c.t_ref_c, c.t_min_c, c.t_max_c);
    std::array<AxisFit, 3> fa{}, fg{};
    for (int a = 0; a < 3; ++a) {
      fa[a] = fitOffset(tf, c.accel, a, kArduTempReference);
      fg[a] = fitOffset(tf, c.gyro, a, kArduTempReference);
    }
    thermalDropped(tf, "accelerometer", c.accel, caltemp, true, fa, &r.dropped);
    thermalDropped(tf, "gyro", c.gyro, caltemp, false, fg, &r.dropped);
    const double xc = caltemp - kArduTempReference;
    auto P = [&](const AxisFit& f) { return (f.c[1] + (f.c[2] + f.c[3] * xc) * xc) * xc; };
    for (int a = 0; a < 3; ++a) {
      const std::string ax(1, kAxes[a]);
      const double s_cal = model::thermalValue(c.accel[model::kScale + a], caltemp - c.t_ref_c, 0);
      w.f("INS_ACCOFFS_" + ax, fa[a].c[0] + P(fa[a]));
      w.f("INS_ACCSCAL_" + ax, 1.0 / s_cal);
      w.f("INS_GYROFFS_" + ax, fg[a].c[0] + P(fg[a]));
    }
    w.f("INS_ACC1_CALTEMP", caltemp);
    w.f("INS_GYR1_CALTEMP", caltemp);
    w.i("INS_TCAL1_ENABLE", 1);
    w.f("INS_TCAL1_TMIN", c.t_min_c);
    w.f("INS_TCAL1_TMAX", c.t_max_c);
    for (int k = 1; k <= 3; ++k)
      for (int a = 0; a < 3; ++a) {
        const std::string ax(1, kAxes[a]);
        w.f("INS_TCAL1_ACC" + std::to_string(k) + "_" + ax, fa[a].c[k] * 1e6);
        w.f("INS_TCAL1_GYR" + std::to_string(k) + "_" + ax, fg[a].c[k] * 1e6);
      }
  }
  std::ostringstream h;
  h << "# imubench export-coeffs --to ardupilot from " << in.source << "\n"
    << "# ArduPilot (AP_InertialSensor_Backend::_rotate_and_correct_accel): v = raw - P(T - 35) + "
       "P(CALTEMP - 35), P(x) = 1e-6 (ACC1 x + ACC2 x^2 + ACC3 x^3), T and CALTEMP clamped to "
       "[TMIN, TMAX];\n"
    << "# accel = (v - INS_ACCOFFS) .* INS_ACCSCAL, gyro = v - INS_GYROFFS (m/s^2, rad/s).\n"
    << "# Gyro offsets are re-measured at every boot unless INS_GYR_CAL = 0.\n";
  for (const std::string& d : r.dropped) h << "# DROPPED: " << d << "\n";
  r.text = h.str() + w.s.str();
  r.status = Status::Ok();
  return r;
}

ExportResult csv(const ExportInput& in) {
  ExportResult r;
  std::ostringstream s;
  s << "triad,coefficient,axis,value\n";
  const char* mis[] = {"xy", "xz", "yx", "yz", "zx", "zy"};
  for (const auto& [name, t] :
       {std::pair<const char*, const TriadModel*>{"accel", &in.sensors.accel},
        {"gyro", &in.sensors.gyro}}) {
    for (int a = 0; a < 3; ++a)
      s << name << ",scale," << kAxes[a] << "," << num(t->scale[a]) << "\n";
    for (int a = 0; a < 3; ++a) s << name << ",bias," << kAxes[a] << "," << num(t->bias[a]) << "\n";
    const double m[] = {t->mis.xy, t->mis.xz, t->mis.yx, t->mis.yz, t->mis.zx, t->mis.zy};
    for (int k = 0; k < 6; ++k) s << name << ",misalignment," << mis[k] << "," << num(m[k]) << "\n";
  }
  if (in.thermal) r.dropped.push_back("the thermal model: write it with `thermal fit --csv`");
  r.text = s.str();
  r.status = Status::Ok();
  return r;
}

}  // namespace

bool exportTargetFromName(const std::string& n, ExportTarget* t) {
  if (n == "kalibr")
    *t = ExportTarget::kKalibr;
  else if (n == "openvins")
    *t = ExportTarget::kOpenVins;
  else if (n == "px4")
    *t = ExportTarget::kPx4;
  else if (n == "ardupilot")
    *t = ExportTarget::kArduPilot;
  else if (n == "csv")
    *t = ExportTarget::kCsv;
  else
    return false;
  return true;
}

ExportResult exportCoefficients(ExportTarget target, const ExportInput& in) {
  switch (target) {
    case ExportTarget::kKalibr:
      return chainYaml(in, true);
    case ExportTarget::kOpenVins:
      return chainYaml(in, false);
    case ExportTarget::kPx4:
      return px4(in);
    case ExportTarget::kArduPilot:
      return ardupilot(in);
    case ExportTarget::kCsv:
      return csv(in);
  }
  return {};
}

}  // namespace imubench::io
