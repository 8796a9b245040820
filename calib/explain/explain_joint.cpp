// explainRecordings (calib/explain/explain.h): one analysis over several recordings of one IMU on
// one bench. Each recording keeps its own bins, forward model along its own encoder spline and
// noise floor; the problem sees their rows one recording after the other, on a time axis where
// each recording starts after the previous one ends (ExplainResult::recording_offsets_s), so
// the correlation and constancy tests treat them as consecutive data.
#include <algorithm>
#include <cmath>
#include <memory>

#include "calib/explain/explain.h"

namespace imubench::calib {
namespace {

// Seconds between one recording's last bin and the next one's first on the joint time axis:
// no bin, window or constancy part spans the join.
constexpr double kJoinGapS = 60.0;

// The recordings' predictions, one after the other (the problem's row order).
class JointPredictor : public ExplainForward {
 public:
  explicit JointPredictor(std::vector<std::unique_ptr<ExplainPredictor>> parts)
      : parts_(std::move(parts)) {}
  void predict(const ExplainState& state, std::vector<double>* out) override {
    out->clear();
    for (const auto& p : parts_) {
      p->predict(state, &one_);
      out->insert(out->end(), one_.begin(), one_.end());
    }
  }
  std::unique_ptr<ExplainForward> clone() const override {
    std::vector<std::unique_ptr<ExplainPredictor>> copies;
    for (const auto& p : parts_) copies.push_back(std::make_unique<ExplainPredictor>(*p));
    return std::make_unique<JointPredictor>(std::move(copies));
  }

 private:
  std::vector<std::unique_ptr<ExplainPredictor>> parts_;
  std::vector<double> one_;
};

// Why the recordings are not of one bench, or "".
std::string otherBench(std::span<const ExplainInput> in) {
  if (in.size() < 2) return "a joint analysis needs at least two recordings";
  for (std::size_t k = 1; k < in.size(); ++k) {
    const std::string which = "recording " + std::to_string(k + 1);
    if (in[k].geometry.kind != in[0].geometry.kind)
      return which + " is of another table kind than recording 1: not the same bench";
    // A site's latitude to 0.01 deg (~1 km) and height to 100 m: one lab.
    if (std::abs(in[k].site.latitude_rad - in[0].site.latitude_rad) > 1.75e-4 ||
        std::abs(in[k].site.height_m - in[0].site.height_m) > 100.0) {
      return which + " was recorded at another site than recording 1: not the same bench";
    }
  }
  return "";
}

// Shifts a recording's bins and segments onto the joint time axis and appends them.
void appendShifted(const ExplainPart& part, std::span<const Segment> segments, double offset,
                   std::vector<ExplainBin>* bins, std::vector<Segment>* all_segments) {
  const int first_segment = static_cast<int>(all_segments->size());
  for (ExplainBin b : part.data.bins) {
    b.t0 += offset;
    b.t1 += offset;
    if (b.segment >= 0) b.segment += first_segment;
    bins->push_back(b);
  }
  for (Segment s : segments) {
    s.t0 += offset;
    s.t1 += offset;
    all_segments->push_back(std::move(s));
  }
}

}  // namespace

ExplainResult explainRecordings(std::span<const ExplainInput> inputs, const ExplainOptions& o) {
  ExplainResult res;
  if (std::string why = otherBench(inputs); !why.empty()) {
    res.status = Status::Error(std::move(why));
    return res;
  }
  std::vector<ExplainPart> parts;
  parts.reserve(inputs.size());  // the predictors point into them
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    parts.push_back(prepareExplainPart(inputs[k], o));
    if (!parts.back().status.ok) {
      res.status =
          Status::Error("recording " + std::to_string(k + 1) + ": " + parts.back().status.message);
      res.unusable = parts.back().unusable;
      return res;
    }
  }
  const ExplainInput& first = inputs[0];
  ExplainProblem p;
  p.noise = parts[0].noise;  // reported; every recording's rows carry their own floor
  p.start.model = first.baseline.values;
  p.start.model.table_kind = first.geometry.kind;
  p.baseline_names = explainBaselineNames(first);
  p.candidates = explainCandidates(first, o);
  p.baseline_method = first.baseline_method;
  std::vector<ExplainBin> bins;
  std::vector<std::unique_ptr<ExplainPredictor>> predictors;
  double end = 0.0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const double offset = k == 0 ? 0.0 : end + kJoinGapS - parts[k].data.bins.front().t0;
    res.recording_offsets_s.push_back(offset);
    appendShifted(parts[k], inputs[k].segments, offset, &bins, &p.segments);
    end = bins.back().t1;
    p.sigma.insert(p.sigma.end(), parts[k].sigma.begin(), parts[k].sigma.end());
    p.model_sigma.insert(p.model_sigma.end(), parts[k].model_sigma.begin(),
                         parts[k].model_sigma.end());
    predictors.push_back(std::make_unique<ExplainPredictor>(&parts[k].data));
    addHarmonicVariants(parts[k].data, o, &p);
  }
  JointPredictor joint(std::move(predictors));
  p.bins = &bins;
  p.forward = &joint;
  const std::vector<double> offsets = res.recording_offsets_s;
  res = analyseProblem(p, o);
  res.recording_offsets_s = offsets;
  if (!res.status.ok) return res;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    ExplainInput in = inputs[k];  // a view: its runs before the refit are at the baseline
    in.baseline = first.baseline;
    for (ExplainRunResidual r : explainRunResiduals(in, res.coefficients.values)) {
      r.label = "rec" + std::to_string(k + 1) + " " + r.label;
      r.t0 += offsets[k];
      r.t1 += offsets[k];
      res.runs.push_back(std::move(r));
    }
  }
  if (const std::string n = explainNavigationNote(res.runs); !n.empty()) res.notes.push_back(n);
  res.notes.push_back(std::to_string(inputs.size()) +
                      " recordings analysed jointly (one IMU, one table: shared coefficients); "
                      "times on the joint axis, recording k starting at its offset");
  return res;
}

}  // namespace imubench::calib
