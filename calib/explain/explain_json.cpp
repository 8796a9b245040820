// The interchange form of an ExplainResult (interchange.md "Explain report").
#include <cmath>
#include <limits>

#include "calib/explain/explain.h"
#include "calib/explain/explain_propose.h"

namespace imubench::calib {
namespace {

nlohmann::json numberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json triads(const std::array<double, 6>& v) {
  return {{"accel", {v[0], v[1], v[2]}}, {"gyro", {v[3], v[4], v[5]}}};
}

nlohmann::json triadsOrNull(const std::array<double, 6>& v) {
  return {{"accel", {numberOrNull(v[0]), numberOrNull(v[1]), numberOrNull(v[2])}},
          {"gyro", {numberOrNull(v[3]), numberOrNull(v[4]), numberOrNull(v[5])}}};
}

// Values of consecutive flat parameters in the shape of a ParamSpec.
nlohmann::json shaped(ParamShape shape, const double* v) {
  switch (shape) {
    case ParamShape::kScalar:
      return numberOrNull(v[0]);
    case ParamShape::kVec3:
      return {numberOrNull(v[0]), numberOrNull(v[1]), numberOrNull(v[2])};
    case ParamShape::kMat3: {
      nlohmann::json m = nlohmann::json::array();
      for (int r = 0; r < 3; ++r) {
        m.push_back(
            {numberOrNull(v[3 * r]), numberOrNull(v[3 * r + 1]), numberOrNull(v[3 * r + 2])});
      }
      return m;
    }
  }
  return nullptr;
}

// {"parameters": .., "sigma": ..} of an accepted effect: the registry's parameter names and
// shapes, or {component: value} for the table's error groups, named by their flat names (their
// order is the table kind's: three-axis nonorthogonality is middle_x, middle_y, inner_y, not
// the registry's inner_y, middle_x, middle_y).
void parametersJson(const ExplainAccepted& a, nlohmann::json* values, nlohmann::json* sigmas) {
  *values = nlohmann::json::object();
  *sigmas = nlohmann::json::object();
  const std::optional<EffectId> id = effectFromName(a.effect);
  if (!id || a.flat_names.size() != static_cast<std::size_t>(flatSize(*id)) ||
      model::kUnitInfos[static_cast<std::size_t>(*id)].stage == model::Stage::kTable) {
    for (std::size_t k = 0; k < a.flat_names.size(); ++k) {
      const std::string comp = a.flat_names[k].substr(a.flat_names[k].rfind('.') + 1);
      (*values)[comp] = numberOrNull(a.values[k]);
      (*sigmas)[comp] = numberOrNull(a.sigmas[k]);
    }
    return;
  }
  std::size_t k = 0;
  for (const ParamSpec& p : paramSpecs(*id)) {
    if (p.kind == ParamKind::kTableAxis) {
      (*values)[p.name] = tableAxisName(static_cast<int>(a.values[k]));
    } else if (p.kind == ParamKind::kInteger) {
      (*values)[p.name] = static_cast<int>(a.values[k]);
    } else {
      (*values)[p.name] = shaped(p.shape, &a.values[k]);
    }
    (*sigmas)[p.name] = shaped(p.shape, &a.sigmas[k]);
    k += static_cast<std::size_t>(paramSize(p.shape));
  }
}

nlohmann::json windowsJson(const std::vector<ExplainWindow>& ws) {
  nlohmann::json out = nlohmann::json::array();
  for (const ExplainWindow& w : ws) {
    out.push_back({{"t0", w.t0},
                   {"t1", w.t1},
                   {"channel", explainChannelName(w.channel)},
                   {"sigma", w.sigma},
                   {"mean", w.mean},
                   {"reason", w.reason}});
  }
  return out;
}

}  // namespace

nlohmann::json toJson(const ExplainResult& r) {
  nlohmann::json j;
  j["format"] = "imubench-explain/1";
  j["baseline"] = {{"method", r.baseline_method}};
  j["noise_floor"] = {{"accel", {r.noise.white[0], r.noise.white[1], r.noise.white[2]}},
                      {"gyro", {r.noise.white[3], r.noise.white[4], r.noise.white[5]}},
                      {"bias_instability", triads(r.noise.bias_instability)},
                      {"bias_instability_tau_s", triads(r.noise.bias_instability_tau_s)}};
  std::array<bool, 6> limited = r.noise.resolution_limited;
  j["noise_floor"]["resolution_limited"] = {{"accel", {limited[0], limited[1], limited[2]}},
                                            {"gyro", {limited[3], limited[4], limited[5]}}};
  j["noise_floor"]["distinct_values"] =
      triads({1.0 * r.noise.distinct_values[0], 1.0 * r.noise.distinct_values[1],
              1.0 * r.noise.distinct_values[2], 1.0 * r.noise.distinct_values[3],
              1.0 * r.noise.distinct_values[4], 1.0 * r.noise.distinct_values[5]});
  // Figures in noise-floor units only where the floor was measured.
  const bool judged = !r.noise.anyResolutionLimited();
  const auto normalised = [judged](double v) { return judged ? numberOrNull(v) : nullptr; };
  std::array<double, 6> channel = r.channel_normalised_rms;
  if (!judged) channel.fill(std::numeric_limits<double>::quiet_NaN());
  j["channel_normalised_rms_after"] = triadsOrNull(channel);
  j["channel_limit"] = triads(r.channel_limit);
  j["channels_above_floor"] = nlohmann::json::array();
  for (int c : channelsAboveFloor(r)) j["channels_above_floor"].push_back(explainChannelName(c));
  j["verdict"] = explainVerdict(r);
  j["rms_before"] = triads(r.rms_before);
  j["rms_after"] = triads(r.rms_after);
  j["noise_rms"] = triads(r.noise_rms);
  j["baseline"]["normalised_rms"] = normalised(r.baseline_normalised_rms);
  j["normalised_rms_after"] = normalised(r.after_normalised_rms);
  j["test_scale"] = r.scale;
  j["residual_correlation"] = r.correlation;  // effective-n factor within test_scale
  j["refit"] = {{"solver", "Gauss-Newton, truncated SVD step, central differences"},
                {"iterations", r.refit.iterations},
                {"converged", r.refit.converged},
                {"last_step_sigma", r.refit.last_step_sigma},
                {"chi2_per_dof", r.refit.chi2_per_dof}};
  // A joint analysis: where each recording starts on the report's time axis.
  if (!r.recording_offsets_s.empty()) j["recording_offsets_s"] = r.recording_offsets_s;
  j["accepted"] = nlohmann::json::array();
  for (const ExplainAccepted& a : r.accepted) {
    nlohmann::json values, sigmas;
    parametersJson(a, &values, &sigmas);
    j["accepted"].push_back({{"effect", a.effect},
                             {"parameters", values},
                             {"sigma", sigmas},
                             {"delta_bic", a.delta_bic},
                             {"lr_stat", a.lr_stat},
                             {"p_value", a.p_value}});
  }
  j["rejected"] = nlohmann::json::array();
  for (const ExplainRejected& x : r.rejected) {
    j["rejected"].push_back(
        {{"effect", x.effect}, {"reason", x.reason}, {"delta_bic", numberOrNull(x.delta_bic)}});
  }
  j["unseparable"] = nlohmann::json::array();
  for (const ExplainUnseparable& u : r.unseparable) {
    j["unseparable"].push_back({{"effects", u.effects}, {"reason", u.reason}});
  }
  j["unexplained"] = windowsJson(r.unexplained);
  j["located"] = windowsJson(r.located);
  j["navigation_residuals"] = nlohmann::json::array();
  for (const ExplainRunResidual& n : r.runs) {
    j["navigation_residuals"].push_back({{"run", n.label},
                                         {"t0", n.t0},
                                         {"t1", n.t1},
                                         {"before_rad", n.before},
                                         {"after_rad", n.after},
                                         {"sigma_rad", n.sigma}});
  }
  j["coefficients"] = toJson(r.coefficients);
  j["notes"] = r.notes;
  return j;
}

nlohmann::json toJson(const ProposedGroup& g, const ProposeResult& p) {
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  nlohmann::json params = nlohmann::json::array();
  for (std::size_t k = 0; k < g.flat_names.size(); ++k) {
    params.push_back({{"name", g.flat_names[k]},
                      {"sigma_before", numberOrNull(g.sigma_before[k])},
                      {"sigma_after", numberOrNull(g.sigma_after[k])},
                      {"sigma_joint", k < g.sigma_joint.size() ? numberOrNull(g.sigma_joint[k])
                                                               : nlohmann::json(nullptr)}});
  }
  return {{"effects", g.effects},
          {"unseparable", g.unseparable},
          {"resolved", g.resolved},
          {"possible", g.possible},
          {"why", g.why},
          {"angle_before_deg", g.angle_before_rad * kDeg},
          {"angle_after_deg", g.angle_after_rad * kDeg},
          {"limit_deg", p.angleLimitFor(g) * kDeg},
          {"added", g.added},
          {"parameters", params}};
}

}  // namespace imubench::calib
