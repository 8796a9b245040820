#include "plans/expand.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "calib/model/motion_profile.h"
#include "calib/model/thermal_lag.h"
#include "nav/rotation.h"

namespace imubench::plans {

bool ExpandOptions::IsValid(std::string* why) const {
  for (double a : initial_angles) {
    if (!std::isfinite(a)) {
      if (why) *why = "initial_angles must be finite";
      return false;
    }
  }
  for (double tau : {thermal.chamber_tau_s, thermal.sensor_tau_s}) {
    if (!std::isfinite(tau) || tau < 0.0) {
      if (why) *why = "thermal time constants must be finite and non-negative";
      return false;
    }
  }
  return true;
}

double profileDuration(double delta, double max_rate, double max_accel) {
  return calib::model::moveDuration(delta, {max_rate, max_accel});
}

namespace {

// The model's rest-to-rest move from angle0 to `target` appended to `axis`; its duration.
double appendProfileTo(calib::AxisTrajectory& axis, double t0, double angle0, double target,
                       double max_rate, double max_accel) {
  if (target == angle0) return 0.0;
  const auto phases = calib::model::moveProfile(t0, calib::AxisState{angle0, 0.0, 0.0}, target,
                                                {max_rate, max_accel});
  for (const calib::AxisPhase& p : phases) axis.append(p);
  return calib::model::profileDuration(phases);
}

}  // namespace

double appendProfile(calib::AxisTrajectory& axis, double t0, double angle0, double delta,
                     double max_rate, double max_accel) {
  if (delta == 0.0) return 0.0;
  return appendProfileTo(axis, t0, angle0, angle0 + delta, max_rate, max_accel);
}

namespace {

// Constant-rate run, as the table does it when told: change to `rate` (signed), hold it for
// `duration` after reaching it, change back to 0. Returns the total time; *turned receives
// the signed angle turned.
double appendRateRun(calib::AxisTrajectory& axis, double t0, double angle0, double rate,
                     double duration, double max_accel, double* turned) {
  const auto up = calib::model::rateProfile(t0, {angle0, 0.0, 0.0}, rate, max_accel);
  const double t_stop = up.back().t0 + duration;
  const auto down =
      calib::model::rateProfile(t_stop, calib::model::profileSample(up, t_stop), 0.0, max_accel);
  for (const calib::AxisPhase& p : up) axis.append(p);
  for (const calib::AxisPhase& p : down) axis.append(p);
  *turned = down.back().angle0 - angle0;
  return down.back().t0 - t0;
}

constexpr long kMaxSegments = 10000000;  // beyond this a plan is surely a typo'd repeat count

class Expander {
 public:
  Expander(const Plan& plan, const ExpandOptions& options) : plan_(plan), lag_(options.thermal) {
    const int n = calib::axisCount(plan.table.kind);
    m_.kind = plan.table.kind;
    m_.axes.resize(static_cast<size_t>(n));
    angle_.assign(static_cast<size_t>(n), 0.0);
    for (int i = 0; i < n && i < static_cast<int>(options.initial_angles.size()); ++i) {
      angle_[static_cast<size_t>(i)] = options.initial_angles[static_cast<size_t>(i)];
    }
    for (int i = 0; i < n; ++i) {
      m_.axes[static_cast<size_t>(i)].append({0.0, angle_[static_cast<size_t>(i)], 0.0, 0.0});
    }
    recording_ = plan.recording_at_start;
    if (plan.chamber) {
      goal_ = plan.chamber->initial.value;
      therm_ = calib::model::thermalAtRest(goal_);
      m_.temperature.push_back({0.0, goal_});
    }
  }

  bool run(std::string* error) {
    if (!steps(plan_.steps, "", error)) return false;
    m_.duration = t_;
    if (!m_.temperature.empty() && m_.temperature.back().t < t_) {
      m_.temperature.push_back({t_, therm_.sensor_c});
    }
    return true;
  }

  calib::Motion take() { return std::move(m_); }

 private:
  const Plan& plan_;
  calib::Motion m_;
  std::vector<double> angle_;  // current angle per axis, rad (continuous)
  double t_ = 0.0;
  // The chamber (plans with [chamber] only): the model's state, its goal and ramp rate.
  calib::model::ThermalLag lag_;
  calib::model::ThermalState therm_;
  double goal_ = 20.0;  // degC
  double ramp_ = 0.0;   // degC/s
  bool recording_ = true;

  static std::string where(const Step& s) {
    return "line " + std::to_string(s.where.line) + " (" + stepTypeName(s.type) + ")";
  }

  // The new segment, or nullptr when it has no length (left out).
  calib::Segment* addSegment(double t0, double t1, calib::SegmentKind kind,
                             const std::string& label, int axis = -1, double angle = 0.0) {
    if (t1 <= t0) return nullptr;
    calib::Segment seg;
    seg.t0 = t0;
    seg.t1 = t1;
    seg.kind = kind;
    seg.label = label;
    seg.recording = recording_;
    seg.axis = axis;
    seg.angle = angle;
    m_.segments.push_back(std::move(seg));
    return &m_.segments.back();
  }

  // A temperature knot now (the IMU's temperature), unless there is one already.
  void addKnot() {
    if (m_.temperature.empty() || m_.temperature.back().t < t_) {
      m_.temperature.push_back({t_, therm_.sensor_c});
    }
  }

  // Time runs on to t1; with a chamber its model (calib/model/thermal_lag.h) runs along,
  // leaving knots at the end of every ramp and, while a lag still settles, every
  // kThermalKnotSpacing (the virtual chamber's history spacing).
  void advanceTime(double t1) {
    const bool lagging = lag_.chamber_tau_s > 0.0 || lag_.sensor_tau_s > 0.0;
    while (plan_.chamber && t_ < t1) {
      const double ramp_end = t_ + calib::model::rampTime(therm_, goal_, ramp_);
      const bool settling = lagging && !calib::model::thermalSettled(therm_, goal_);
      double tn = ramp_end > t_ ? std::min(t1, ramp_end) : t1;
      if (settling) {
        const double spacing = calib::model::kThermalKnotSpacing;
        const double next = std::max(m_.temperature.back().t + spacing, t_ + 1e-3 * spacing);
        tn = std::min(tn, next);
      }
      therm_ = calib::model::advanceThermal(therm_, goal_, ramp_, lag_, tn - t_);
      t_ = tn;
      if (settling || t_ == ramp_end) addKnot();
    }
    t_ = t1;
  }

  // The axis a step names and the profile it moves with: the step's rate/accel, else the
  // table's limits for that axis.
  struct AxisProfile {
    int axis = 0;
    size_t ui = 0;  // the same, as an index
    double rate = 0.0;
    double accel = 0.0;
  };
  bool profileOf(const Step& s, const std::string& name, AxisProfile* out, std::string* error) {
    const auto i = axisIndex(plan_.table.kind, name);
    if (!i) {
      *error = where(s) + ": unknown axis \"" + name + "\"";
      return false;
    }
    const EffectiveLimits lim = limitsFor(plan_.table, *i);
    const auto r = s.rate ? std::optional<double>(std::abs(s.rate->value)) : lim.max_rate;
    const auto a = s.accel ? std::optional<double>(s.accel->value) : lim.max_accel;
    if (!r || !a || !(*r > 0.0) || !(*a > 0.0)) {
      *error = where(s) + ": no usable rate/accel limit for this axis (validate the plan)";
      return false;
    }
    *out = {*i, static_cast<size_t>(*i), *r, *a};
    return true;
  }

  // move: every named axis from where it is to its target at once; done when the last arrives.
  bool move(const Step& s, const std::string& label, std::string* error) {
    double longest = 0.0;
    int moved = 0;
    int moved_axis = -1;
    double moved_delta = 0.0;
    for (const AxisTarget& target : s.targets) {
      AxisProfile p;
      if (!profileOf(s, target.axis, &p, error)) return false;
      const bool limited = limitsFor(plan_.table, p.axis).limited;
      double delta = target.angle.value - angle_[p.ui];
      if (!limited) delta = std::remainder(delta, 2.0 * kPi);  // shortest way
      // Keep the angle continuous; on limited axes land exactly on the written target.
      const double to = limited ? target.angle.value : angle_[p.ui] + delta;
      const double d = appendProfileTo(m_.axes[p.ui], t_, angle_[p.ui], to, p.rate, p.accel);
      angle_[p.ui] = to;
      if (delta != 0.0) {
        ++moved;
        moved_axis = p.axis;
        moved_delta = delta;
      }
      longest = std::max(longest, d);
    }
    if (moved == 1) {
      addSegment(t_, t_ + longest, calib::SegmentKind::kMove, label, moved_axis, moved_delta);
    } else {
      addSegment(t_, t_ + longest, calib::SegmentKind::kMove, label);
    }
    advanceTime(t_ + longest);
    return true;
  }

  // rotate (by an angle) and rate (a constant-rate run): one axis turns.
  bool turn(const Step& s, const std::string& label, std::string* error) {
    AxisProfile p;
    if (!profileOf(s, s.axis, &p, error)) return false;
    double d = 0.0;
    double turned = 0.0;
    if (s.type == StepType::kRotate) {
      d = appendProfile(m_.axes[p.ui], t_, angle_[p.ui], s.angle.value, p.rate, p.accel);
      turned = s.angle.value;
      angle_[p.ui] += turned;
    } else {
      if (!(s.duration.value > 0.0) || !s.rate || s.rate->value == 0.0) {
        *error = where(s) + ": rate run needs a nonzero rate and a positive duration";
        return false;
      }
      d = appendRateRun(m_.axes[p.ui], t_, angle_[p.ui], s.rate->value, s.duration.value, p.accel,
                        &turned);
      angle_[p.ui] = m_.axes[p.ui].phases().back().angle0;  // where the table stops
    }
    addSegment(t_, t_ + d, calib::SegmentKind::kRotate, label, p.axis, turned);
    advanceTime(t_ + d);
    return true;
  }

  // The chamber's ramp rate for a chamber or thermal step (its own, else [chamber] max_ramp).
  bool rampOf(const Step& s, double* ramp, std::string* error) const {
    if (!plan_.chamber) {
      *error = where(s) + ": chamber step without a [chamber] section";
      return false;
    }
    *ramp = s.ramp ? s.ramp->value : plan_.chamber->max_ramp.value;
    if (!(*ramp > 0.0)) {
      *error = where(s) + ": ramp must be positive";
      return false;
    }
    return true;
  }

  // A kSoak segment: the chamber ramps to goal_c, then soaks for the step's fixed time or, with
  // soak = "auto", for the model's predicted settling time (calib/model/thermal_lag.h).
  bool chamberSoak(const Step& s, double goal_c, const std::string& label, std::string* error) {
    double ramp = 0.0;
    if (!rampOf(s, &ramp, error)) return false;
    if (s.soak.value < 0.0 || (s.soak_auto && (!s.max_soak || !(s.settle_rate.value > 0.0) ||
                                               !(s.settle_hold.value > 0.0)))) {
      *error = where(s) +
               ": soak must be non-negative, an auto soak needs a positive settle_rate, "
               "settle_hold and max_soak";
      return false;
    }
    const double t_ramp = calib::model::rampTime(therm_, goal_c, ramp);
    double duration = t_ramp + s.soak.value;
    if (s.soak_auto) {
      const calib::model::SettleCriterion c{s.settle_rate.value, s.settle_hold.value};
      duration = calib::model::settlingTime(therm_, goal_c, ramp, lag_, c, s.max_soak->value).t_s;
    }
    addKnot();
    goal_ = goal_c;
    ramp_ = ramp;
    if (calib::Segment* seg = addSegment(t_, t_ + duration, calib::SegmentKind::kSoak, label)) {
      seg->setpoint_c = goal_;
      seg->ramp_s = t_ramp;
      seg->ramp_c_per_s = ramp;
      if (s.soak_auto) {
        seg->soak_auto = true;
        seg->settle_rate_c_per_s = s.settle_rate.value;
        seg->settle_hold_s = s.settle_hold.value;
        seg->max_soak_s = s.max_soak->value;
      }
    }
    advanceTime(t_ + duration);
    return true;
  }

  // "T-40C", "T22.5C": a setpoint as a label prefix.
  static std::string tempLabel(double c) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "T%gC", std::round(c * 100.0) / 100.0 + 0.0);
    return buf;
  }

  // thermal: per setpoint (leg order) a soak then the body ("T-40C/..."), or in ramp mode the
  // chamber told to go there and the body repeated while the model's ramp lasts
  // ("ramp1/rep03/...").
  bool thermal(const Step& s, const std::string& prefix, std::string* error) {
    double ramp = 0.0;
    if (!rampOf(s, &ramp, error)) return false;
    const std::string base = prefix + (s.label.empty() ? "" : s.label + "/");
    const std::vector<double> points = thermalSetpoints(s.setpoints, s.legs);
    std::vector<std::pair<double, int>> visits;  // setpoint, times seen
    for (std::size_t leg = 0; leg < points.size(); ++leg) {
      const double sp = points[leg];
      if (s.mode == ThermalMode::kSoak) {
        int seen = 1;
        for (auto& v : visits) {
          if (v.first == sp) seen = ++v.second;
        }
        if (seen == 1) visits.push_back({sp, 1});
        const std::string p =
            base + tempLabel(sp) + (seen > 1 ? "#" + std::to_string(seen) : "") + "/";
        if (!chamberSoak(s, sp, p + "soak", error) || !steps(s.steps, p, error)) return false;
        continue;
      }
      const double t_leg = t_;
      const double t_ramp = calib::model::rampTime(therm_, sp, ramp);
      addKnot();
      goal_ = sp;
      ramp_ = ramp;
      const std::size_t first_seg = m_.segments.size();
      for (int rep = 1;; ++rep) {
        char buf[48];
        std::snprintf(buf, sizeof buf, "ramp%zu/rep%02d/", leg + 1, rep);
        const double t_rep = t_;
        if (!steps(s.steps, base + buf, error)) return false;
        if (!(t_ > t_rep)) {
          *error = where(s) + ": the body of a ramp takes no time";
          return false;
        }
        if (t_ - t_leg >= t_ramp) break;
      }
      if (first_seg < m_.segments.size()) {
        m_.segments[first_seg].chamber_command_c = sp;
        m_.segments[first_seg].ramp_c_per_s = ramp;
      }
    }
    return true;
  }

  bool steps(const std::vector<Step>& list, const std::string& prefix, std::string* error) {
    for (const Step& s : list) {
      if (!step(s, prefix, error)) return false;
    }
    return true;
  }

  bool step(const Step& s, const std::string& prefix, std::string* error) {
    if (!s.complete) {
      *error = where(s) + ": step has parse errors";
      return false;
    }
    if (static_cast<long>(m_.segments.size()) > kMaxSegments) {
      *error = "plan expands to more than " + std::to_string(kMaxSegments) + " segments";
      return false;
    }
    const std::string label = prefix + (s.label.empty() ? stepTypeName(s.type) : s.label);
    switch (s.type) {
      case StepType::kHold: {
        if (!(s.duration.value > 0.0)) {
          *error = where(s) + ": duration must be positive";
          return false;
        }
        addSegment(t_, t_ + s.duration.value, calib::SegmentKind::kStatic, label);
        advanceTime(t_ + s.duration.value);
        return true;
      }
      case StepType::kMove:
        return move(s, label, error);
      case StepType::kRotate:
      case StepType::kRate:
        return turn(s, label, error);
      case StepType::kChamber:
        return chamberSoak(s, s.setpoint.value, label, error);
      case StepType::kThermal:
        return thermal(s, prefix, error);
      case StepType::kRecord:
        recording_ = s.record_on;
        return true;
      case StepType::kRepeat: {
        if (s.count < 1) {
          *error = where(s) + ": repeat count must be at least 1";
          return false;
        }
        const std::string base = prefix + (s.label.empty() ? "repeat" : s.label);
        for (int k = 1; k <= s.count; ++k) {
          const std::string p = base + (s.count > 1 ? "#" + std::to_string(k) : "") + "/";
          if (!steps(s.steps, p, error)) return false;
        }
        return true;
      }
    }
    return true;
  }
};

}  // namespace

ExpandResult expand(const Plan& plan, const ExpandOptions& options) {
  ExpandResult r;
  std::string why;
  if (!options.IsValid(&why)) {
    r.status = Status::Error(why);
    return r;
  }
  const int n = calib::axisCount(plan.table.kind);
  if (!options.initial_angles.empty() && static_cast<int>(options.initial_angles.size()) != n) {
    r.status =
        Status::Error("initial_angles must have one entry per axis (" + std::to_string(n) + ")");
    return r;
  }
  Expander e(plan, options);
  if (!e.run(&why)) {
    r.status = Status::Error(why);
    return r;
  }
  r.motion = e.take();
  r.status = Status::Ok();
  return r;
}

}  // namespace imubench::plans
