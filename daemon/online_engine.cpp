#include "daemon/online_engine.h"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>

#include "calib/static_detection.h"
#include "daemon/run_explain.h"
#include "daemon/store.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

using nlohmann::json;

// Degrees per hour in rad/s (the unit gyro noise and biases are shown in).
constexpr double kDegPerHour = kDegToRad / 3600.0;

json vec(const Eigen::Vector3d& v, double per_unit) {
  return json::array({v.x() / per_unit, v.y() / per_unit, v.z() / per_unit});
}

// The run so far as one recording: the run's meta data with the sealed chunks concatenated.
io::Recording recordingOf(
    const io::Recording& meta, const std::vector<std::shared_ptr<const nav::ImuSamples>>& imu,
    const std::vector<std::shared_ptr<const std::vector<io::TableSample>>>& table,
    const std::vector<calib::Segment>& segments) {
  io::Recording rec = meta;
  std::size_t n = 0;
  for (const auto& c : imu) n += c->size();
  rec.imu.reserve(n);
  for (const auto& c : imu) rec.imu.insert(rec.imu.end(), c->begin(), c->end());
  for (const auto& c : table) rec.table.insert(rec.table.end(), c->begin(), c->end());
  rec.segments = segments;
  return completeSegmentsOnly(std::move(rec), nullptr);
}

std::string timeSpan(double t0, double t1) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(3) << t0 << "-" << t1 << " s";
  return s.str();
}

// Removes the first segment gap (t_a, t_b) harms (as calib's checkIncrements judges it); false
// when it harms none.
bool leaveOutOne(std::vector<calib::Segment>* segments, double t_a, double t_b,
                 std::vector<std::string>* notes) {
  std::optional<std::size_t> before, after, inside;
  for (std::size_t k = 0; k < segments->size(); ++k) {
    const calib::Segment& s = (*segments)[k];
    if (s.t0 < t_b && s.t1 > t_a) inside = k;
    if (s.t1 <= t_a && (!before || s.t1 > (*segments)[*before].t1)) before = k;
    if (s.t0 >= t_b && (!after || s.t0 < (*segments)[*after].t0)) after = k;
  }
  const bool rotate_before = before && (*segments)[*before].kind == calib::SegmentKind::kRotate;
  const bool rotate_after = after && (*segments)[*after].kind == calib::SegmentKind::kRotate;
  const std::optional<std::size_t> out = inside          ? inside
                                         : rotate_before ? before
                                         : rotate_after  ? after
                                                         : std::nullopt;
  if (!out) return false;
  const calib::Segment& s = (*segments)[*out];
  if (notes) {
    notes->push_back("segment '" + s.label + "' (" + timeSpan(s.t0, s.t1) +
                     ") left out: " + (inside ? "it spans" : "a rotation next to") +
                     " the gap in the IMU data " + timeSpan(t_a, t_b));
  }
  segments->erase(segments->begin() + static_cast<std::ptrdiff_t>(*out));
  return true;
}

// One line for people: how much the estimate determines.
std::string summaryOf(const json& estimate, const std::string& method) {
  const std::size_t estimated = estimate["parameters"].size();
  const std::size_t unobservable = estimate["unobservable"].size();
  std::string s = method + ": " + std::to_string(estimated) + " parameters estimated, " +
                  std::to_string(unobservable) + " not yet observable";
  if (estimate.contains("reason")) s += " (" + estimate["reason"].get<std::string>() + ")";
  return s;
}

}  // namespace

void StepStats::add(const nav::ImuSample& s, double dt) {
  if (samples == 0) t0 = s.t;
  t1 = s.t;
  ++samples;
  dtheta += s.dtheta;
  dvel += s.dvel;
  const Eigen::Vector3d f = s.dvel / dt;
  const Eigen::Vector3d w = s.dtheta / dt;
  const double n = static_cast<double>(samples);
  const Eigen::Vector3d df = f - f_mean;
  const Eigen::Vector3d dw = w - w_mean;
  f_mean += df / n;
  w_mean += dw / n;
  f_m2 += df.cwiseProduct(f - f_mean);
  w_m2 += dw.cwiseProduct(w - w_mean);
}

json StepStats::toJson() const {
  json j = {{"samples", samples}, {"duration_s", samples > 0 ? t1 - t0 : 0.0}};
  if (samples < 2) return j;
  const double n1 = static_cast<double>(samples - 1);
  if (kind == calib::SegmentKind::kStatic) {
    j["specific_force_mps2"] = vec(f_mean, 1.0);
    j["rate_deg_h"] = vec(w_mean, kDegPerHour);
    j["accel_noise_mps2"] = vec((f_m2 / n1).cwiseSqrt(), 1.0);
    j["gyro_noise_deg_h"] = vec((w_m2 / n1).cwiseSqrt(), kDegPerHour);
  } else {
    j["turned_deg"] = vec(dtheta, kDegToRad);
    j["dvel_mps"] = vec(dvel, 1.0);
  }
  return j;
}

OnlineEngine::OnlineEngine(OnlineSetup setup, OffLoop* worker, Publish publish)
    : setup_(std::move(setup)),
      worker_(worker),
      publish_(std::move(publish)),
      reference_(std::make_shared<Reference>()),
      imu_(std::make_shared<nav::ImuSamples>()),
      alive_(std::make_shared<bool>(true)) {}

OnlineEngine::~OnlineEngine() {
  *alive_ = false;
}

void OnlineEngine::addImu(std::span<const nav::ImuSample> samples) {
  for (const nav::ImuSample& s : samples) {
    if (stats_ && last_t_ && s.t > *last_t_) stats_->add(s, s.t - *last_t_);
    last_t_ = s.t;
    imu_->push_back(s);
  }
}

void OnlineEngine::addTable(const io::TableSample& sample) {
  table_.push_back(sample);
}

void OnlineEngine::stepStarted(int step, calib::SegmentKind kind) {
  stats_.emplace();
  stats_->step = step;
  stats_->kind = kind;
}

void OnlineEngine::sealChunk() {
  if (!imu_->empty()) {
    sealed_.imu.push_back(std::move(imu_));
    imu_ = std::make_shared<nav::ImuSamples>();
  }
  if (!table_.empty()) {
    sealed_.table.push_back(
        std::make_shared<const std::vector<io::TableSample>>(std::move(table_)));
    table_.clear();
  }
}

json OnlineEngine::stepFinished(const std::optional<calib::Segment>& segment,
                                const std::string& label) {
  json stats = stats_ ? stats_->toJson() : json::object();
  const int step = stats_ ? stats_->step : -1;
  stats_.reset();
  sealChunk();
  if (!segment || setup_.method == plans::CalibrationMethod::kNone) return stats;
  sealed_.segments.push_back(*segment);
  if (!makesEstimatePossible(*segment)) return stats;
  last_step_ = step;
  last_label_ = label;
  if (in_flight_) {
    pending_ = true;
  } else {
    startEstimate();
  }
  return stats;
}

// direct: every hold and rotation adds a row. Navigation-based: a pair of rotations with the
// hold after the second (a run's residuals need the holds on both sides).
bool OnlineEngine::makesEstimatePossible(const calib::Segment& segment) {
  if (!segment.recording) return false;
  if (setup_.method == plans::CalibrationMethod::kDirect) {
    return segment.kind == calib::SegmentKind::kStatic ||
           segment.kind == calib::SegmentKind::kRotate;
  }
  if (segment.kind == calib::SegmentKind::kRotate) ++rotations_done_;
  if (segment.kind != calib::SegmentKind::kStatic) return false;
  if (rotations_done_ % 2 != 0 || rotations_done_ == rotations_estimated_) return false;
  rotations_estimated_ = rotations_done_;
  return true;
}

void OnlineEngine::startEstimate() {
  pending_ = false;
  const int step = last_step_;
  const std::string label = last_label_;
  auto job = [chunks = sealed_, meta = setup_.meta, method = setup_.method,
              direct_run = setup_.direct_run, db = setup_.db_path, reference = reference_,
              known = setup_.known_table_errors, alive = alive_, step, label,
              this]() -> std::function<void()> {
    const io::Recording rec = recordingOf(meta, chunks.imu, chunks.table, chunks.segments);
    if (method == plans::CalibrationMethod::kPipeline && !reference->tried && direct_run) {
      reference->tried = true;
      auto opened = Store::open(db, StoreOptions{});
      auto loaded = opened.status.ok ? opened.value->loadRecording(*direct_run)
                                     : io::RecordingReadResult{opened.status, {}};
      if (loaded.status.ok) {
        reference->recording = std::move(loaded.value);
      } else {
        reference->error = loaded.status.message;
      }
    }
    RunCalibration c =
        calibrateRun(method, rec, reference->recording ? &*reference->recording : nullptr, known);
    if (!c.status.ok && !reference->error.empty())
      c.status.message += " (direct run: " + reference->error + ")";
    return [this, alive, c = std::move(c), step, label] {
      if (*alive) onEstimate(c, step, label);
    };
  };
  auto failed = [this, alive = alive_, step, label](const std::string& what) {
    if (!*alive) return;
    RunCalibration c;
    c.status = Status::Error("estimate failed: " + what);
    onEstimate(c, step, label);
  };
  std::string why;
  in_flight_ = worker_->run(job, failed, &why);
  pending_ = !in_flight_;  // no worker free now: the next step's end tries again
}

void OnlineEngine::onEstimate(const RunCalibration& c, int step, const std::string& label) {
  in_flight_ = false;
  const char* method = plans::calibrationMethodName(setup_.method);
  json fields = estimateJson(c);
  fields["run"] = setup_.run_id;
  fields["step"] = step;
  fields["label"] = label;
  fields["method"] = method;
  fields["report"] = c.report;
  fields["summary"] = label + ": " + summaryOf(fields, method);
  ++published_;
  publish_(fields);
  if (pending_) startEstimate();
}

io::Recording completeSegmentsOnly(io::Recording rec, std::vector<std::string>* notes) {
  if (rec.imu.size() < 2) return rec;
  const double max_gap =
      calib::IncrementCheckOptions{}.max_gap_factor * calib::medianSampleStep(rec.imu);
  for (std::size_t i = 1; i < rec.imu.size(); ++i) {
    const double t_a = rec.imu[i - 1].t, t_b = rec.imu[i].t;
    if (!(t_b - t_a > max_gap)) continue;
    while (leaveOutOne(&rec.segments, t_a, t_b, notes)) {
    }
  }
  return rec;
}

FinalCalibration finalCalibration(const OnlineSetup& setup) {
  FinalCalibration out;
  auto opened = Store::open(setup.db_path, StoreOptions{});
  if (!opened.status.ok) {
    out.status = opened.status;
    return out;
  }
  auto run = opened.value->loadRecording(setup.run_id);
  if (!run.status.ok) {
    out.status = run.status;
    return out;
  }
  // Complete segments only: a gap (a daemon restart, an IMU restart) is left between them.
  std::vector<std::string> left_out;
  run.value = completeSegmentsOnly(std::move(run.value), &left_out);
  std::optional<io::Recording> direct;
  if (setup.direct_run) {
    auto d = opened.value->loadRecording(*setup.direct_run);
    if (!d.status.ok) {
      out.status = Status::Error("direct run " + std::to_string(*setup.direct_run) + ": " +
                                 d.status.message);
      return out;
    }
    direct = completeSegmentsOnly(std::move(d.value), &left_out);
  }
  const auto temperature = runTemperature(run.value);
  if (!temperature) {
    out.status = Status::Error("run " + std::to_string(setup.run_id) +
                               " recorded no temperature (no chamber samples, no IMU temperature)");
    return out;
  }
  out.status = Status::Ok();
  out.imu_serial = run.value.imu_serial;
  out.temperature_c = *temperature;
  const RunCalibration c =
      calibrateRun(setup.method, run.value, direct ? &*direct : nullptr, setup.known_table_errors);
  out.calibrated = c.status.ok;
  if (c.status.ok) out.coefficients = calib::toJson(c.coefficients);
  out.report = c.report;
  out.report["ok"] = c.status.ok;
  if (!c.status.ok) out.report["error"] = c.status.message;
  out.report["estimate"] = estimateJson(c);
  if (setup.direct_run) out.report["direct_run"] = *setup.direct_run;
  if (!left_out.empty()) out.report["segments_left_out"] = left_out;
  out.report["temperature_c"] = *temperature;
  out.report["table_kind"] =
      run.value.table_kind == calib::TableKind::kTwoAxis ? "two-axis" : "three-axis";
  if (run.value.table_kind == calib::TableKind::kTwoAxis)
    out.report["outer_axis_heading_deg"] = run.value.outerAxisHeadingDeg();
  out.verdict = acceptanceVerdict(c, setup.acceptance);
  // The missing-physics analysis from the final coefficients, on this worker like them.
  std::optional<FollowUpSetup> follow_up;
  if (setup.follow_up) {
    follow_up = FollowUpSetup{setup.run_id, setup.method, setup.direct_run, *setup.follow_up};
  }
  RunExplain e =
      explainRun(setup.method, run.value, c, setup.explain, follow_up ? &*follow_up : nullptr);
  out.follow_up = std::move(e.follow_up);
  if (e.status.ok) {
    out.explain = std::move(e.report);
    out.explain_summary = std::move(e.summary);
  } else {
    out.explain_error = "missing-physics analysis not stored: " + e.status.message;
    out.verdict["notes"].push_back(out.explain_error);
  }
  return out;
}

}  // namespace imubench::daemon
