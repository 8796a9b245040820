#include "nav/free_navigation.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace imubench::nav {

bool FreeNavOptions::IsValid(std::string* why) const {
  if (!mech.IsValid(why)) return false;
  if (!(output_interval_s > 0.0) || !std::isfinite(output_interval_s)) {
    if (why) *why = "output_interval_s must be a positive number of seconds";
    return false;
  }
  if (!reference_v_L.allFinite()) {
    if (why) *why = "reference_v_L must be finite";
    return false;
  }
  if (!(max_interval_ratio > 1.0)) {
    if (why) *why = "max_interval_ratio must be > 1";
    return false;
  }
  return true;
}

const char* freeNavStatusName(FreeNavStatus s) {
  switch (s) {
    case FreeNavStatus::kOk:
      return "ok";
    case FreeNavStatus::kInvalidOptions:
      return "invalid options";
    case FreeNavStatus::kBadInitialState:
      return "bad initial state";
    case FreeNavStatus::kBadTimestamps:
      return "bad time stamps";
    case FreeNavStatus::kGap:
      return "gap in samples";
    case FreeNavStatus::kNonFinite:
      return "non-finite increments";
  }
  return "unknown";
}

FreeNavigator::FreeNavigator(const NavState& initial, const FreeNavOptions& opt)
    : opt_(opt), state_(initial), initial_(initial) {
  prev_sample_.t = initial.t;
  std::string why;
  if (!opt_.IsValid(&why)) {
    init_status_ = FreeNavStatus::kInvalidOptions;
    init_message_ = why;
    return;
  }
  const bool finite = std::isfinite(initial.t) && std::isfinite(initial.lat_rad) &&
                      std::isfinite(initial.lon_rad) && std::isfinite(initial.height_m) &&
                      initial.v_L.allFinite() && initial.q_BtoL.coeffs().allFinite() &&
                      initial.q_BtoL.norm() > 0.5;
  if (!finite || std::abs(initial.lat_rad) >= 0.5 * kPi) {
    init_status_ = FreeNavStatus::kBadInitialState;
    init_message_ =
        "initial state must be finite with a unit attitude quaternion and |latitude| < 90 deg";
    return;
  }
  state_.q_BtoL.normalize();
  initial_ = state_;
  const Radii r0 = radiiOfCurvature(initial.lat_rad);
  rm_h0_ = r0.meridian + initial.height_m;
  rn_cos_h0_ = (r0.prime_vertical + initial.height_m) * std::cos(initial.lat_rad);
  next_output_t_ = initial.t + opt_.output_interval_s;
}

NavErrorPoint FreeNavigator::pointOf(const NavState& s) const {
  NavErrorPoint p;
  p.t = s.t;
  const Vec3 dv = s.v_L - opt_.reference_v_L;
  p.v_E_err = dv.x();
  p.v_N_err = dv.y();
  p.v_U_err = dv.z();
  p.d_E_m = (s.lon_rad - initial_.lon_rad) * rn_cos_h0_;
  p.d_N_m = (s.lat_rad - initial_.lat_rad) * rm_h0_;
  p.q_BtoL = s.q_BtoL;
  return p;
}

NavErrorPoint FreeNavigator::current() const {
  return pointOf(state_);
}

NavErrorPoint FreeNavigator::initialPoint() const {
  return pointOf(initial_);  // position errors are exactly zero here
}

FreeNavigator::FeedResult FreeNavigator::feed(const ImuSample& sample) {
  FeedResult r;
  if (init_status_ != FreeNavStatus::kOk) {
    r.status = init_status_;
    r.message = init_message_;
    return r;
  }
  const double dt = sample.t - state_.t;
  if (!(dt > 0.0) || !std::isfinite(sample.t)) {
    std::ostringstream m;
    m << "sample at t = " << sample.t << " s does not follow the previous time " << state_.t
      << " s";
    r.status = FreeNavStatus::kBadTimestamps;
    r.message = m.str();
    return r;
  }
  if (!sample.dtheta.allFinite() || !sample.dvel.allFinite()) {
    std::ostringstream m;
    m << "sample at t = " << sample.t << " s has non-finite increments";
    r.status = FreeNavStatus::kNonFinite;
    r.message = m.str();
    return r;
  }
  const bool gap = nominal_dt_ > 0.0 && dt > opt_.max_interval_ratio * nominal_dt_;
  if (gap && opt_.gap_policy == GapPolicy::kStop) {
    std::ostringstream m;
    m << "gap before t = " << sample.t << " s: interval " << dt << " s is more than "
      << opt_.max_interval_ratio << " x the sample interval " << nominal_dt_ << " s";
    r.status = FreeNavStatus::kGap;
    r.message = m.str();
    return r;
  }
  if (gap) {
    // Bridge: the lost samples' motion is unknown; hold this sample's rates over the missing
    // time. No coning/sculling across the gap (their previous-sample terms assume contiguity).
    const double missing = dt - nominal_dt_;
    ImuSample fill;
    fill.t = state_.t + missing;
    fill.dtheta = sample.dtheta * (missing / nominal_dt_);
    fill.dvel = sample.dvel * (missing / nominal_dt_);
    state_ = insMech(state_, ImuSample{}, fill, opt_.mech);
    prev_sample_ = ImuSample{};
    ++gaps_bridged_;
    r.gap_bridged = true;
    std::ostringstream m;
    m << "bridged a gap of " << missing << " s before t = " << sample.t << " s";
    r.message = m.str();
  }
  // Running mean interval (tracks slow clock drift; a gap does not enter it).
  const double step = gap ? nominal_dt_ : dt;
  nominal_dt_ = nominal_dt_ == 0.0 ? step : 0.99 * nominal_dt_ + 0.01 * step;

  state_ = insMech(state_, prev_sample_, sample, opt_.mech);
  prev_sample_ = sample;

  // Output when the state reaches the next output time (within a tiny fraction of a
  // sample, so exactly aligned times are not missed to rounding).
  if (state_.t >= next_output_t_ - 1e-6 * nominal_dt_) {
    r.output = current();
    const double k = std::floor((state_.t - initial_.t) / opt_.output_interval_s + 1e-6) + 1.0;
    next_output_t_ = initial_.t + k * opt_.output_interval_s;
  }
  return r;
}

FreeNavResult navigateFree(const NavState& initial, std::span<const ImuSample> samples,
                           const FreeNavOptions& opt) {
  FreeNavResult result;
  FreeNavigator nav(initial, opt);
  result.final_state = initial;
  if (nav.status() != FreeNavStatus::kOk) {
    result.status = nav.status();
    result.message = nav.statusMessage();
    return result;
  }
  if (!samples.empty()) {
    const double span = samples.back().t - initial.t;
    if (span > 0.0)
      result.series.reserve(static_cast<std::size_t>(span / opt.output_interval_s) + 2);
  }
  result.series.push_back(nav.initialPoint());
  for (const ImuSample& s : samples) {
    FreeNavigator::FeedResult fr = nav.feed(s);
    if (fr.status != FreeNavStatus::kOk) {
      result.status = fr.status;
      result.message = fr.message;
      break;
    }
    if (fr.output) result.series.push_back(*fr.output);
    ++result.samples_used;
  }
  result.final_state = nav.state();
  result.gaps_bridged = nav.gapsBridged();
  return result;
}

double firstIntervalStart(std::span<const ImuSample> samples) {
  if (samples.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  return samples[0].t - (samples[1].t - samples[0].t);
}

}  // namespace imubench::nav
