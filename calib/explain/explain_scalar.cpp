#include "calib/explain/explain_scalar.h"

#include <cctype>
#include <cmath>
#include <memory>
#include <string>

#include "calib/model/sensor_equation.h"
#include "calib/simulator.h"
#include "nav/earth.h"

namespace imubench::calib {
namespace {

// The static poses cut into bins, their holds (for the noise floor) and their segments.
struct PoseBins {
  std::vector<ExplainBin> bins;
  std::vector<Segment> segments;
  std::vector<HoldReadings> holds;
  std::vector<Vec3> mean_accel;  // per pose, readings
};

// Mean readings of samples [i0, i1) as one bin of pose p.
ExplainBin binOf(const RawImuData& d, std::size_t i0, std::size_t i1, double dt, int p) {
  ExplainBin b;
  b.t0 = d.t[i0] - 0.5 * dt;
  b.t1 = d.t[i1 - 1] + 0.5 * dt;
  b.segment = p;
  Vec3 a = Vec3::Zero(), w = Vec3::Zero();
  for (std::size_t i = i0; i < i1; ++i) {
    a += d.accel[i];
    w += d.gyro[i];
  }
  const double n = static_cast<double>(i1 - i0);
  for (int c = 0; c < 3; ++c) {
    b.measured[static_cast<std::size_t>(c)] = a(c) / n;
    b.measured[static_cast<std::size_t>(c) + 3] = w(c) / n;
  }
  return b;
}

// One pose: trimmed samples, its hold, its bins (bin_s long; a short tail joins the last).
void addPose(const RawImuData& d, const StaticSpan& s, double trim_s, double bin_s, PoseBins* out) {
  std::size_t i0 = s.begin, i1 = s.end;
  while (i0 < i1 && d.t[i0] < s.t0 + trim_s) ++i0;
  while (i1 > i0 && d.t[i1 - 1] > s.t1 - trim_s) --i1;
  if (i1 - i0 < 8) return;
  const double dt = (d.t[i1 - 1] - d.t[i0]) / static_cast<double>(i1 - i0 - 1);
  const int p = static_cast<int>(out->segments.size());
  Segment seg;
  seg.t0 = d.t[i0] - 0.5 * dt;
  seg.t1 = d.t[i1 - 1] + 0.5 * dt;
  seg.kind = SegmentKind::kStatic;
  seg.label = "pose " + std::to_string(p + 1);
  out->segments.push_back(seg);
  HoldReadings h;
  h.dt = dt;
  h.accel.assign(d.accel.begin() + static_cast<std::ptrdiff_t>(i0),
                 d.accel.begin() + static_cast<std::ptrdiff_t>(i1));
  h.gyro.assign(d.gyro.begin() + static_cast<std::ptrdiff_t>(i0),
                d.gyro.begin() + static_cast<std::ptrdiff_t>(i1));
  out->holds.push_back(std::move(h));
  const std::size_t per_bin = std::max<std::size_t>(1, std::llround(bin_s / dt));
  Vec3 sum = Vec3::Zero();
  for (std::size_t a = i0; a < i1; a += per_bin) {
    std::size_t b = std::min(i1, a + per_bin);
    if (i1 - b < per_bin / 2) b = i1;  // a short tail joins this bin
    out->bins.push_back(binOf(d, a, b, dt, p));
    for (std::size_t i = a; i < b; ++i) sum += d.accel[i];
    if (b == i1) break;
  }
  out->mean_accel.push_back(sum / static_cast<double>(i1 - i0));
}

// Two unit vectors orthogonal to u (and to each other).
void tangentBasis(const Vec3& u, Vec3* e1, Vec3* e2) {
  const Vec3 ref = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  *e1 = u.cross(ref).normalized();
  *e2 = u.cross(*e1);
}

// The poses' forward model: gravity along each pose's direction (two nuisance angles about
// the start direction); the rate is the Earth rate's vertical component along the same
// direction (one nuisance parameter, rad/s, after the poses' angles: its horizontal part
// depends on the unknown headings and is carried as uncertainty); the library's sensor
// equation and reading effects.
class ScalarPredictor : public ExplainForward {
 public:
  ScalarPredictor(const std::vector<ExplainBin>* bins, const std::vector<Vec3>& u0,
                  const nav::Site& site)
      : bins_(bins), u0_(u0), site_(site) {
    for (const Vec3& u : u0_) {
      Vec3 e1, e2;
      tangentBasis(u, &e1, &e2);
      e1_.push_back(e1);
      e2_.push_back(e2);
    }
  }
  void predict(const ExplainState& s, std::vector<double>* out) override {
    const double g = nav::siteGravity(trueSite(site_, s.model.extra));
    const ForwardModel model(s.model.sensors, s.model.extra);
    out->resize(bins_->size() * 6);
    for (std::size_t b = 0; b < bins_->size(); ++b) {
      const std::size_t p = static_cast<std::size_t>((*bins_)[b].segment);
      const Vec3 u =
          (u0_[p] + s.nuisance[2 * p] * e1_[p] + s.nuisance[2 * p + 1] * e2_[p]).normalized();
      PhysicsPoint pt;
      pt.f_B = g * u;
      pt.w_IB_B = s.nuisance[2 * u0_.size()] * u;
      pt.temp_c = (*bins_)[b].temp_c;
      const Readings r = model.readings(pt);
      for (int c = 0; c < 3; ++c) {
        (*out)[b * 6 + static_cast<std::size_t>(c)] = r.accel(c);
        (*out)[b * 6 + 3 + static_cast<std::size_t>(c)] = r.gyro(c);
      }
    }
  }
  std::unique_ptr<ExplainForward> clone() const override {
    return std::make_unique<ScalarPredictor>(*this);
  }

 private:
  const std::vector<ExplainBin>* bins_;
  std::vector<Vec3> u0_, e1_, e2_;
  nav::Site site_;
};

// The baseline's parameters: what the scalar calibration determined of the accelerometer
// triad (observable ones), the gyro biases, and the poses' directions.
std::vector<std::string> scalarBaselineNames(const CoefficientReport& report, std::size_t poses) {
  std::vector<std::string> names;
  for (const std::string& n : flatNames(report.values)) {
    const bool accel = n.rfind("accel.", 0) == 0;
    if (!accel && n.rfind("gyro.bias.", 0) != 0) continue;
    const auto it = report.uncertainty.find(n);
    if (accel && it != report.uncertainty.end() && !it->second.observable) continue;
    names.push_back(n);
  }
  for (std::size_t k = 0; k < 2 * poses + 1; ++k) {
    names.push_back("nuisance." + std::to_string(k));
  }
  return names;
}

// Per-row sigmas: the noise floor over each bin's duration; the gyro rows also carry the
// horizontal Earth rate along the pose's unknown heading (model part: does not average down),
// horizontal_rate rad/s.
std::vector<double> scalarRowSigmas(const std::vector<ExplainBin>& bins, const NoiseFloor& nf,
                                    const TriadModel& gyro, double horizontal_rate,
                                    std::vector<double>* model) {
  std::vector<double> s(bins.size() * 6);
  model->assign(s.size(), 0.0);
  for (std::size_t b = 0; b < bins.size(); ++b) {
    for (int c = 0; c < 6; ++c) {
      const double earth = c < 3 ? 0.0 : std::abs(gyro.scale(c - 3)) * horizontal_rate;
      s[b * 6 + static_cast<std::size_t>(c)] =
          std::hypot(nf.sigmaOfMean(c, bins[b].duration()), earth);
      (*model)[b * 6 + static_cast<std::size_t>(c)] = earth;
    }
  }
  return s;
}

// What nuisance parameter k of the poses' model is, for people: the attitude angles of a pose,
// or the vertical Earth rate (after the poses' angles).
std::string nuisanceMeaning(std::size_t k, std::size_t poses) {
  if (k >= 2 * poses) return "the vertical Earth rate";
  return "the attitude of pose " + std::to_string(k / 2 + 1) + " (tilt angle " +
         std::to_string(k % 2 + 1) + ")";
}

// Replaces every "nuisance.N" in s by its meaning.
std::string readable(std::string s, std::size_t poses) {
  static const std::string kPrefix = "nuisance.";
  for (std::size_t at = s.find(kPrefix); at != std::string::npos; at = s.find(kPrefix, at)) {
    std::size_t end = at + kPrefix.size();
    while (end < s.size() && std::isdigit(static_cast<unsigned char>(s[end]))) ++end;
    if (end == at + kPrefix.size()) {
      at = end;
      continue;
    }
    const std::string m = nuisanceMeaning(
        std::stoul(s.substr(at + kPrefix.size(), end - at - kPrefix.size())), poses);
    s.replace(at, end - at, m);
    at += m.size();
  }
  return s;
}

// The result's messages with the nuisance parameters' internal names replaced by their meaning.
void readableNuisanceNames(std::size_t poses, ExplainResult* res) {
  res->status.message = readable(res->status.message, poses);
  for (ExplainRejected& x : res->rejected) x.reason = readable(x.reason, poses);
  for (ExplainUnseparable& u : res->unseparable) u.reason = readable(u.reason, poses);
  for (std::string& n : res->notes) n = readable(n, poses);
}

}  // namespace

ExplainResult explainScalar(const RawImuData& data, const ScalarCalibrationOptions& scalar,
                            bool accel_unit_is_si, const ExplainOptions& options) {
  ExplainResult res;
  std::string why;
  if (!options.IsValid(&why)) {
    res.status = Status::Error("options: " + why);
    return res;
  }
  const ScalarCalibrationResult cal = scalarCalibrate(data, scalar, accel_unit_is_si);
  if (!cal.status.ok) {
    res.status = Status::Error("scalar calibration (the baseline): " + cal.status.message);
    // Too few or too short static poses: the recording cannot support the analysis (what
    // `imubench calibrate` refuses as unusable too).
    res.unusable = cal.status.code == RecordingStatusCode::kTooFewStatics ||
                   cal.status.code == RecordingStatusCode::kTooShortStatic;
    return res;
  }
  PoseBins pb;
  for (const StaticSpan& s : cal.spans) {
    addPose(data, s, scalar.span_trim_s, options.model.bin_s, &pb);
  }
  ExplainProblem p;
  p.noise = noiseFloor(pb.holds, options.noise);
  if (!p.noise.status.ok) {
    res.status = Status::Error("the static poses are too short for an Allan deviation");
    return res;
  }
  std::vector<Vec3> u0;
  const auto accel_block = cal.accel().block();
  for (const Vec3& m : pb.mean_accel)
    u0.push_back(model::input(accel_block.data(), m).normalized());
  nav::Site site;
  site.latitude_rad = scalar.latitude_rad.value_or(0.0);
  site.gravity_mps2 = scalar.gravity_mps2;
  ScalarPredictor predictor(&pb.bins, u0, site);
  p.bins = &pb.bins;
  p.forward = &predictor;
  // Latitude known: the vertical Earth rate starts at its value and the horizontal part is
  // Omega cos(lat); unknown: it starts at zero and all of Omega may lie horizontal.
  const double lat = scalar.latitude_rad.value_or(0.0);
  const double horizontal = scalar.latitude_rad ? nav::kEarthRate * std::cos(lat) : nav::kEarthRate;
  p.sigma = scalarRowSigmas(pb.bins, p.noise, cal.gyro(), horizontal, &p.model_sigma);
  p.start.model = cal.report.values;
  p.start.nuisance.assign(2 * u0.size() + 1, 0.0);
  p.start.nuisance.back() = scalar.latitude_rad ? nav::kEarthRate * std::sin(lat) : 0.0;
  p.baseline_names = scalarBaselineNames(cal.report, u0.size());
  p.candidates = registryCandidates(options);
  p.segments = pb.segments;
  p.baseline_method = "scalar";
  res = analyseProblem(p, options);
  readableNuisanceNames(u0.size(), &res);
  if (res.status.ok) {
    res.notes.insert(res.notes.begin(),
                     std::to_string(u0.size()) + " static poses of the scalar calibration; " +
                         "the Earth rate's vertical component (along gravity) is fitted, its "
                         "horizontal part (unknown headings) is carried as gyro-row "
                         "uncertainty");
  }
  return res;
}

}  // namespace imubench::calib
