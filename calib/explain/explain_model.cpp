#include "calib/explain/explain_model.h"

#include <algorithm>
#include <cmath>

#include "calib/model/bench_physics.h"
#include "calib/static_detection.h"
#include "nav/free_navigation.h"

namespace imubench::calib {
namespace {

// Gauss-Legendre nodes on [-1, 1].
constexpr std::array<double, 2> kGl2 = {-0.57735026918962576, 0.57735026918962576};
constexpr std::array<double, 3> kGl3 = {-0.77459666924148338, 0.0, 0.77459666924148338};
constexpr std::array<double, 3> kGl3Weights = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};

// An axis turning by less than this inside a bin (and at rates below it per second at the
// encoder samples) counts as still: encoder interpolation ringing stays far below it.
constexpr double kStillRad = 1e-7;

// Linear interpolation of the IMU's temperature (only finite values), 20 degC without any.
class TemperatureSeries {
 public:
  explicit TemperatureSeries(std::span<const nav::ImuSample> imu) {
    for (const nav::ImuSample& s : imu) {
      if (std::isfinite(s.temp_c)) {
        t_.push_back(s.t);
        v_.push_back(s.temp_c);
      }
    }
  }
  double at(double t) const {
    if (t_.empty()) return 20.0;
    const auto it = std::lower_bound(t_.begin(), t_.end(), t);
    if (it == t_.begin()) return v_.front();
    if (it == t_.end()) return v_.back();
    const std::size_t k = static_cast<std::size_t>(it - t_.begin());
    const double f = (t - t_[k - 1]) / (t_[k] - t_[k - 1]);
    return v_[k - 1] + f * (v_[k] - v_[k - 1]);
  }

 private:
  std::vector<double> t_, v_;
};

int segmentOf(std::span<const Segment> segments, double t, std::size_t* hint) {
  while (*hint < segments.size() && segments[*hint].t1 < t) ++*hint;
  if (*hint < segments.size() && segments[*hint].t0 <= t && t <= segments[*hint].t1) {
    return static_cast<int>(*hint);
  }
  return -1;
}

bool binMoves(const ExplainData& d, double t0, double t1) {
  for (const AxisSpline& a : d.axes) {
    if (std::abs(a.at(t1).angle - a.at(t0).angle) > kStillRad) return true;
    const std::vector<double>& k = a.knots();
    for (auto it = std::lower_bound(k.begin(), k.end(), t0); it != k.end() && *it <= t1; ++it) {
      if (std::abs(a.at(*it).rate) > kStillRad) return true;
    }
  }
  return false;
}

// Quadrature nodes of one bin: 3-point Gauss-Legendre over a still bin, 2-point over every
// encoder interval of a moving one (the spline is one cubic there).
void addNodes(ExplainData* d, ExplainBin* bin, const TemperatureSeries& temp) {
  bin->node_begin = d->nodes.size();
  const double T = bin->duration();
  if (!bin->moving) {
    for (std::size_t k = 0; k < kGl3.size(); ++k) {
      const double t = bin->t0 + 0.5 * T * (1.0 + kGl3[k]);
      d->nodes.push_back({t, 0.5 * kGl3Weights[k], temp.at(t)});
    }
  } else {
    std::vector<double> cuts = {bin->t0};
    for (const AxisSpline& a : d->axes) {
      const std::vector<double>& k = a.knots();
      for (auto it = std::upper_bound(k.begin(), k.end(), bin->t0); it != k.end() && *it < bin->t1;
           ++it) {
        cuts.push_back(*it);
      }
    }
    cuts.push_back(bin->t1);
    std::sort(cuts.begin(), cuts.end());
    for (std::size_t p = 0; p + 1 < cuts.size(); ++p) {
      const double a = cuts[p], b = cuts[p + 1];
      if (b <= a) continue;
      for (double x : kGl2) {
        const double t = 0.5 * (a + b) + 0.5 * (b - a) * x;
        d->nodes.push_back({t, 0.5 * (b - a) / T, temp.at(t)});
      }
    }
  }
  bin->node_end = d->nodes.size();
}

// Splines of the encoder angles of every axis through every stride-th sample (and the last).
std::vector<AxisSpline> axisSplines(TableKind kind, std::span<const TableSample> table,
                                    std::size_t stride) {
  std::vector<AxisSpline> out;
  for (int axis = 0; axis < axisCount(kind); ++axis) {
    std::vector<double> t, y;
    for (std::size_t i = 0; i < table.size(); ++i) {
      if (i % stride != 0 && i + 1 != table.size()) continue;
      const TableSample& s = table[i];
      const double a = axis == 0                                    ? s.angles.outer
                       : (kind == TableKind::kTwoAxis || axis == 2) ? s.angles.inner
                                                                    : s.angles.middle;
      double v = a;
      if (!y.empty()) v = y.back() + std::remainder(a - y.back(), 2.0 * kPi);  // unwrap
      t.push_back(s.t);
      y.push_back(v);
    }
    out.emplace_back(std::move(t), std::move(y));
  }
  return out;
}

// Lagrange weights of the cubic through (x[j], .) at 0, j = 0..3 (the x distinct).
std::array<double, 4> cubicWeightsAtZero(const std::array<double, 4>& x) {
  std::array<double, 4> w{};
  for (std::size_t j = 0; j < 4; ++j) {
    w[j] = 1.0;
    for (std::size_t k = 0; k < 4; ++k) {
      if (k != j) w[j] *= (0.0 - x[k]) / (x[j] - x[k]);
    }
  }
  return w;
}

}  // namespace

double encoderTimeSigma(const std::vector<AxisSpline>& axes) {
  // Below this rate a sample's time error is not measurable against the encoder's resolution.
  constexpr double kMinRate = 1e-3;  // rad/s
  std::vector<double> scaled;        // |time error| / its standard deviation's factor
  for (const AxisSpline& a : axes) {
    const std::vector<double>& t = a.knots();
    const std::vector<double>& y = a.values();
    for (std::size_t i = 2; i + 2 < t.size(); ++i) {
      const std::array<double, 4> x{t[i - 2] - t[i], t[i - 1] - t[i], t[i + 1] - t[i],
                                    t[i + 2] - t[i]};
      if (!(x[0] < x[1] && x[1] < 0.0 && 0.0 < x[2] && x[2] < x[3])) continue;
      const double rate = (y[i + 1] - y[i - 1]) / (x[2] - x[1]);
      if (std::abs(rate) < kMinRate || y[i - 2] == y[i - 1] || y[i + 1] == y[i + 2]) continue;
      const std::array<double, 4> w = cubicWeightsAtZero(x);
      const double predicted =
          w[0] * y[i - 2] + w[1] * y[i - 1] + w[2] * y[i + 1] + w[3] * y[i + 2];
      double gain = 1.0;  // the sample's own error and its neighbours' through the weights
      for (double v : w) gain += v * v;
      scaled.push_back(std::abs(y[i] - predicted) / std::abs(rate) / std::sqrt(gain));
    }
  }
  if (scaled.size() < 20) return 0.0;
  auto mid = scaled.begin() + static_cast<std::ptrdiff_t>(scaled.size() / 2);
  std::nth_element(scaled.begin(), mid, scaled.end());
  return 1.4826 * *mid;  // median absolute deviation of a normal scatter
}

bool ExplainModelOptions::IsValid(std::string* why) const {
  if (!(bin_s > 0.0 && bin_s <= 60.0)) {
    *why = "bin_s must be in (0, 60] s";
    return false;
  }
  return true;
}

AxisSpline::AxisSpline(std::vector<double> t, std::vector<double> angle)
    : t_(std::move(t)), y_(std::move(angle)), m_(t_.size(), 0.0) {
  const std::size_t n = t_.size();
  if (n < 3) return;
  // Natural spline: tridiagonal system for the second derivatives (Thomas algorithm).
  std::vector<double> c(n, 0.0), r(n, 0.0);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double h0 = t_[i] - t_[i - 1], h1 = t_[i + 1] - t_[i];
    const double diag = 2.0 * (h0 + h1) - h0 * c[i - 1];
    c[i] = h1 / diag;
    const double rhs = 6.0 * ((y_[i + 1] - y_[i]) / h1 - (y_[i] - y_[i - 1]) / h0);
    r[i] = (rhs - h0 * r[i - 1]) / diag;
  }
  for (std::size_t i = n - 2; i >= 1; --i) {
    m_[i] = r[i] - c[i] * m_[i + 1];
    if (i == 1) break;
  }
}

AxisState AxisSpline::at(double t) const {
  if (t_.empty()) return {};
  if (t_.size() == 1 || t <= t_.front()) return {y_.front(), 0.0, 0.0};
  if (t >= t_.back()) return {y_.back(), 0.0, 0.0};
  const std::size_t k =
      static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
  const double h = t_[k] - t_[k - 1];
  const double a = (t_[k] - t) / h, b = (t - t_[k - 1]) / h;
  const double m0 = m_[k - 1], m1 = m_[k];
  AxisState s;
  s.angle = a * y_[k - 1] + b * y_[k] + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
  s.rate = (y_[k] - y_[k - 1]) / h - (3.0 * a * a - 1.0) * h * m0 / 6.0 +
           (3.0 * b * b - 1.0) * h * m1 / 6.0;
  s.accel = a * m0 + b * m1;
  return s;
}

ExplainData prepareExplainData(const TableGeometry& geometry, const nav::Site& site,
                               std::span<const nav::ImuSample> imu,
                               std::span<const TableSample> table,
                               std::span<const Segment> segments,
                               const ExplainModelOptions& options) {
  ExplainData d;
  d.geometry = geometry;
  d.site = site;
  d.axes = axisSplines(geometry.kind, table, 1);
  if (imu.empty() || table.size() < 2) return d;
  const std::vector<AxisSpline> coarse = axisSplines(geometry.kind, table, 2);
  // Largest estimated angle error within half an encoder interval of t (the model may be
  // evaluated there when a timing effect shifts it).
  const double half_step =
      0.5 * (table.back().t - table.front().t) / static_cast<double>(table.size() - 1);
  d.stamp_sigma_s = encoderTimeSigma(d.axes);
  auto angleErr = [&](double t) {
    double e2 = 0.0;
    for (std::size_t a = 0; a < d.axes.size(); ++a) {
      double e = 0.0;
      for (double s : {t - half_step, t, t + half_step}) {
        const AxisState fine = d.axes[a].at(s);
        e = std::max(e, std::abs(fine.angle - coarse[a].at(s).angle) / 3.0);
        e = std::max(e, std::abs(fine.rate) * d.stamp_sigma_s);
      }
      e2 += e * e;
    }
    return std::sqrt(e2);
  };
  const double t_first = table.front().t, t_last = table.back().t;
  const TemperatureSeries temp(imu);
  std::size_t hint = 0;
  double t_start = nav::firstIntervalStart(imu);
  ExplainBin bin;
  std::array<double, 6> sum{};
  double temp_sum = 0.0;
  int count = 0;
  auto close = [&](double t_end) {
    bin.t1 = t_end;
    for (int c = 0; c < 6; ++c) bin.measured[c] = sum[c] / bin.duration();
    bin.temp_c = temp_sum / count;
    bin.moving = binMoves(d, bin.t0, bin.t1);
    bin.angle_err_ends = std::hypot(angleErr(bin.t0), angleErr(bin.t1));
    bin.angle_err_inside = bin.angle_err_ends;
    if (bin.moving) {
      for (double f : {0.25, 0.5, 0.75}) {
        bin.angle_err_inside =
            std::max(bin.angle_err_inside, angleErr(bin.t0 + f * bin.duration()));
      }
    }
    addNodes(&d, &bin, temp);
    d.bins.push_back(bin);
    sum = {};
    temp_sum = 0.0;
    count = 0;
  };
  // A sample after a gap (the daemon was down between two segments: the caller's check lets
  // only such gaps through) covers an unknown interval: it is left out and no bin spans it.
  const double max_step = 5.0 * medianSampleStep(imu);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const nav::ImuSample& s = imu[i];
    const bool after_gap = i > 0 && max_step > 0.0 && s.t - t_start > max_step;
    if (after_gap || t_start < t_first || s.t > t_last) {  // no encoder kinematics here
      if (count > 0) close(t_start);
      t_start = s.t;
      continue;
    }
    const int seg = segmentOf(segments, 0.5 * (t_start + s.t), &hint);
    if (count > 0 && seg != bin.segment) close(t_start);
    if (count == 0) {
      bin = ExplainBin{};
      bin.t0 = t_start;
      bin.segment = seg;
    }
    for (int c = 0; c < 3; ++c) {
      sum[c] += s.dvel(c);
      sum[c + 3] += s.dtheta(c);
    }
    temp_sum += temp.at(s.t);
    ++count;
    t_start = s.t;
    if (s.t - bin.t0 >= options.bin_s * (1.0 - 1e-9)) close(s.t);
  }
  if (count > 0) close(t_start);
  return d;
}

double timeDelayOf(const EffectSet& effects) {
  const auto v = effects.param(EffectId::kTimeDelay, "tau_s");
  return effects.has(EffectId::kTimeDelay) && v && !v->empty() ? v->front() : 0.0;
}

double accelDelayOf(const EffectSet& effects) {
  const std::optional<EffectId> id = effectFromName("accel_delay");
  if (!id || !effects.has(*id)) return 0.0;
  const auto v = effects.param(*id, "tau_s");
  return v && !v->empty() ? v->front() : 0.0;
}

ExplainPredictor::PhysicsKey ExplainPredictor::keyOf(const BenchTruth& model) const {
  PhysicsKey k;
  const TableErrors& e = model.table;
  k.table = {e.base_tilt.x(),
             e.base_tilt.y(),
             e.nonorthogonality.inner_y,
             e.nonorthogonality.middle_x,
             e.nonorthogonality.middle_y,
             e.mounting.x(),
             e.mounting.y(),
             e.encoder_zero.outer,
             e.encoder_zero.middle,
             e.encoder_zero.inner,
             0.0,
             0.0,
             0.0};
  const nav::Site s = trueSite(data_->site, model.extra);
  k.latitude = s.latitude_rad;
  k.gravity = nav::siteGravity(s);
  k.tau = timeDelayOf(model.extra);
  k.tau_accel = accelDelayOf(model.extra);
  if (const auto& h = model.extra.angle_harmonic) {
    k.harmonic = {static_cast<double>(h->axis), h->order, h->cos_rad, h->sin_rad};
  }
  return k;
}

PhysicsPoint ExplainPredictor::physicsAt(const TableModel& table, const EffectSet& extra,
                                         double gravity, const Vec3& w_ie_L, double t,
                                         double temp_c) const {
  TableState state;
  state.outer = data_->axes[0].at(t);
  if (data_->geometry.kind == TableKind::kTwoAxis) {
    state.inner = data_->axes[1].at(t);
  } else {
    state.middle = data_->axes[1].at(t);
    state.inner = data_->axes[2].at(t);
  }
  if (extra.angle_harmonic) state = trueTableState(state, extra);  // encoder -> true angles
  const TableKinematics k = table.kinematics(state);
  const model::Physics<double> m = model::benchPhysics(k, gravity, w_ie_L);
  PhysicsPoint p;
  p.f_B = m.f_B;
  p.w_IB_B = m.w_IB_B;
  p.w_LB_B = m.w_LB_B;
  p.wdot_LB_B = m.wdot_LB_B;
  p.temp_c = temp_c;
  return p;
}

void ExplainPredictor::computePhysics(const BenchTruth& model, const PhysicsKey& key) {
  const TableModel table(data_->geometry, model.table);
  const Vec3 w_ie_L = nav::earthRateL(key.latitude);
  physics_.resize(data_->nodes.size());
  accel_physics_.clear();
  if (key.tau_accel != 0.0) accel_physics_.resize(data_->nodes.size());
  for (std::size_t i = 0; i < data_->nodes.size(); ++i) {
    const QuadratureNode& n = data_->nodes[i];
    physics_[i] = physicsAt(table, model.extra, key.gravity, w_ie_L, n.t - key.tau, n.temp_c);
    if (key.tau_accel != 0.0) {
      accel_physics_[i] = physicsAt(table, model.extra, key.gravity, w_ie_L,
                                    n.t - key.tau - key.tau_accel, n.temp_c);
    }
  }
  key_ = key;
  have_physics_ = true;
}

double stateValue(const ExplainState& s, const std::string& name) {
  if (name.rfind("nuisance.", 0) == 0) {
    const std::size_t k = std::stoul(name.substr(9));
    return k < s.nuisance.size() ? s.nuisance[k] : 0.0;
  }
  return flatValue(s.model, name).value_or(0.0);
}

bool setStateValue(ExplainState* s, const std::string& name, double value, std::string* why) {
  if (name.rfind("nuisance.", 0) == 0) {
    const std::size_t k = std::stoul(name.substr(9));
    if (k >= s->nuisance.size()) {
      *why = "no nuisance parameter " + name;
      return false;
    }
    s->nuisance[k] = value;
    return true;
  }
  return setFlatValue(&s->model, name, value, why);
}

void ExplainPredictor::predict(const ExplainState& state, std::vector<double>* out) {
  const BenchTruth& model = state.model;
  const PhysicsKey key = keyOf(model);
  if (!have_physics_ || !(key == key_)) computePhysics(model, key);
  out->assign(data_->bins.size() * 6, 0.0);
  const ForwardModel forward(model.sensors, model.extra);  // parameter blocks prepared once
  for (std::size_t b = 0; b < data_->bins.size(); ++b) {
    const ExplainBin& bin = data_->bins[b];
    Vec3 accel = Vec3::Zero(), gyro = Vec3::Zero();
    for (std::size_t i = bin.node_begin; i < bin.node_end; ++i) {
      const double w = data_->nodes[i].weight;
      const Readings r = forward.readings(physics_[i]);
      gyro += w * r.gyro;
      if (accel_physics_.empty()) {
        accel += w * r.accel;
      } else {
        accel += w * forward.readings(accel_physics_[i]).accel;
      }
    }
    for (int c = 0; c < 3; ++c) {
      (*out)[b * 6 + c] = accel(c);
      (*out)[b * 6 + 3 + c] = gyro(c);
    }
  }
}

}  // namespace imubench::calib
