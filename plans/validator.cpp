#include "plans/validator.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

#include "nav/rotation.h"
#include "plans/expand.h"

namespace imubench::plans {

bool ValidatorOptions::IsValid(std::string* why) const {
  if (!(ambiguous_move_tolerance >= 0.0 && ambiguous_move_tolerance < 0.5 * kPi)) {
    if (why) *why = "ambiguous_move_tolerance must be in [0, 90) deg";
    return false;
  }
  if (max_unrolled_steps < 1) {
    if (why) *why = "max_unrolled_steps must be >= 1";
    return false;
  }
  return true;
}

namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
std::string deg(double rad) {
  return num(rad * kRadToDeg) + " deg";
}
std::string degs(double rad_s) {
  return num(rad_s * kRadToDeg) + " deg/s";
}
std::string degs2(double rad_s2) {
  return num(rad_s2 * kRadToDeg) + " deg/s^2";
}

// Allowance for rounding in unit conversion: a value written equal to its limit passes.
bool above(double v, double limit) {
  return v > limit * (1.0 + 1e-12) + 1e-15;
}

class Validator {
 public:
  Validator(const Plan& plan, io::Diagnostics& diag, const ValidatorOptions& options)
      : plan_(plan), diag_(diag), opt_(options) {}

  bool run() {
    const size_t before = diag_.items().size();
    std::string why;
    if (!opt_.IsValid(&why)) {
      diag_.error(0, 0, "validator options: " + why);
      return false;
    }
    checkTable();
    checkChamber();
    checkSteps(plan_.steps);
    const long unrolled = unrolledCount(plan_.steps, true);
    if (unrolled > opt_.max_unrolled_steps && !reported_unroll_) {
      error(plan_.plan_where,
            "the plan unrolls to more than " + std::to_string(opt_.max_unrolled_steps) + " steps");
    }
    if (unrolled <= opt_.max_unrolled_steps) {
      angle_.assign(static_cast<size_t>(calib::axisCount(plan_.table.kind)), 0.0);
      recording_ = plan_.recording_at_start;
      simulate(plan_.steps);
      if (opt_.require_recording && !records_) {
        error(plan_.plan_where,
              "the plan never records: no step runs with recording on (add a record step with "
              "state = \"on\")");
      }
    }
    return diag_.items().size() == before;
  }

 private:
  const Plan& plan_;
  io::Diagnostics& diag_;
  const ValidatorOptions& opt_;
  std::set<std::tuple<int, int, std::string>> seen_;  // repeats must not repeat diagnostics
  std::vector<double> angle_;
  bool recording_ = true;
  bool records_ = false;
  bool reported_unroll_ = false;

  void error(SourcePos p, std::string msg) {
    if (!seen_.insert({p.line, p.column, msg}).second) return;
    diag_.error(p.line, p.column, std::move(msg));
  }

  std::string axisList() const {
    std::string s;
    for (auto n : axisNames(plan_.table.kind)) s += (s.empty() ? "" : ", ") + std::string(n);
    return s;
  }

  std::optional<int> axis(const std::string& name, SourcePos where) {
    auto i = axisIndex(plan_.table.kind, name);
    if (!i) {
      error(where, "unknown axis \"" + name + "\": a " + tableKindName(plan_.table.kind) +
                       " table has " + axisList());
    }
    return i;
  }

  void checkTable() {
    const TableSpec& t = plan_.table;
    if (t.max_rate && !(t.max_rate->value > 0.0))
      error(t.max_rate->where, "max_rate must be positive");
    if (t.max_accel && !(t.max_accel->value > 0.0)) {
      error(t.max_accel->where, "max_accel must be positive");
    }
    for (const AxisLimits& a : t.axes) {
      if (!axisIndex(t.kind, a.axis)) {
        error(a.where, "unknown axis \"" + a.axis + "\" in [table." + a.axis + "]: a " +
                           tableKindName(t.kind) + " table has " + axisList());
        continue;
      }
      if (a.max_rate && !(a.max_rate->value > 0.0))
        error(a.max_rate->where, "max_rate must be positive");
      if (a.max_accel && !(a.max_accel->value > 0.0)) {
        error(a.max_accel->where, "max_accel must be positive");
      }
      if (a.min_angle && a.max_angle && !(a.min_angle->value < a.max_angle->value)) {
        error(a.min_angle->where, "min_angle must be below max_angle");
      }
    }
    const auto names = axisNames(t.kind);
    for (int i = 0; i < static_cast<int>(names.size()); ++i) {
      const EffectiveLimits lim = limitsFor(t, i);
      const std::string n(names[static_cast<size_t>(i)]);
      if (!lim.max_rate) {
        error(t.where, "no rate limit for the " + n + " axis: give max_rate in [table] or [table." +
                           n + "]");
      }
      if (!lim.max_accel) {
        error(t.where, "no acceleration limit for the " + n +
                           " axis: give max_accel in [table] or [table." + n + "]");
      }
    }
  }

  void checkChamber() {
    if (!plan_.chamber) return;
    const ChamberSpec& c = plan_.chamber.value();
    if (!(c.min_temp.value < c.max_temp.value)) {
      error(c.min_temp.where, "chamber min_temp must be below max_temp");
    }
    if (!(c.max_ramp.value > 0.0)) error(c.max_ramp.where, "chamber max_ramp must be positive");
    if (c.initial.value < c.min_temp.value || c.initial.value > c.max_temp.value) {
      error(c.initial.where.line ? c.initial.where : c.where,
            "chamber initial temperature " + num(c.initial.value) + " degC outside [" +
                num(c.min_temp.value) + ", " + num(c.max_temp.value) + "] degC");
    }
  }

  // Rate/accel magnitudes given on a step against one axis's limits.
  void checkMotionLimits(const Step& s, int i, const std::string& axis_name, bool signed_rate) {
    const EffectiveLimits lim = limitsFor(plan_.table, i);
    if (s.rate) {
      const double r = std::abs(s.rate->value);
      if (!(r > 0.0)) {
        error(s.rate->where, signed_rate ? "rate must not be zero" : "rate must be positive");
      } else if (!signed_rate && s.rate->value < 0.0) {
        error(s.rate->where, "rate must be positive (the direction comes from the angle)");
      } else if (lim.max_rate && above(r, *lim.max_rate)) {
        error(s.rate->where,
              "rate " + degs(r) + " above the " + axis_name + " axis limit " + degs(*lim.max_rate));
      }
    }
    if (s.accel) {
      if (!(s.accel->value > 0.0)) {
        error(s.accel->where, "accel must be positive");
      } else if (lim.max_accel && above(s.accel->value, *lim.max_accel)) {
        error(s.accel->where, "accel " + degs2(s.accel->value) + " above the " + axis_name +
                                  " axis limit " + degs2(*lim.max_accel));
      }
    }
  }

  // Checks that do not depend on where the table is: once per written step.
  void checkSteps(const std::vector<Step>& steps, bool in_thermal = false) {
    for (const Step& s : steps) {
      if (!s.complete) {
        if (s.type == StepType::kRepeat || s.type == StepType::kThermal) {
          checkSteps(s.steps, in_thermal || s.type == StepType::kThermal);
        }
        continue;
      }
      switch (s.type) {
        case StepType::kMove:
          for (const AxisTarget& t : s.targets) {
            auto i = axis(t.axis, t.axis_where);
            if (!i) continue;
            checkMotionLimits(s, *i, t.axis, false);
            const EffectiveLimits lim = limitsFor(plan_.table, *i);
            if (lim.limited && (t.angle.value < lim.min_angle || t.angle.value > lim.max_angle)) {
              error(t.angle.where, "target " + deg(t.angle.value) + " outside the " + t.axis +
                                       " axis range [" + deg(lim.min_angle) + ", " +
                                       deg(lim.max_angle) + "]");
            }
          }
          break;
        case StepType::kRotate: {
          if (s.angle.value == 0.0) error(s.angle.where, "rotate by zero: remove the step");
          if (auto i = axis(s.axis, s.axis_where)) checkMotionLimits(s, *i, s.axis, false);
          break;
        }
        case StepType::kRate: {
          if (auto i = axis(s.axis, s.axis_where)) {
            checkMotionLimits(s, *i, s.axis, true);
            if (limitsFor(plan_.table, *i).limited) {
              error(s.axis_where, "a constant-rate run needs a continuous axis; the " + s.axis +
                                      " axis is limited to a position range");
            }
          }
          if (!(s.duration.value > 0.0)) {
            error(s.duration.where,
                  "duration must be positive, got " + num(s.duration.value) + " s");
          }
          break;
        }
        case StepType::kHold:
          if (!(s.duration.value > 0.0)) {
            error(s.duration.where,
                  "duration must be positive, got " + num(s.duration.value) + " s");
          }
          break;
        case StepType::kChamber:
          if (in_thermal) {
            error(s.where,
                  "a chamber step inside a thermal step's body would fight its setpoints: "
                  "move it out");
          }
          checkChamberStep(s, {Quantity{s.setpoint}});
          break;
        case StepType::kThermal:
          if (in_thermal) error(s.where, "a thermal step inside a thermal step's body");
          checkChamberStep(s, s.setpoints);
          checkSteps(s.steps, true);
          break;
        case StepType::kRecord:
          break;
        case StepType::kRepeat:
          if (s.count < 1) {
            error(s.count_where, "repeat count must be at least 1, got " + std::to_string(s.count));
          }
          checkSteps(s.steps, in_thermal);
          break;
      }
    }
  }

  // A chamber or thermal step: its setpoints, ramp and soak against the [chamber] limits.
  void checkChamberStep(const Step& s, const std::vector<Quantity>& setpoints) {
    if (!plan_.chamber) {
      error(s.where, std::string(stepTypeName(s.type)) +
                         " step but the plan has no [chamber] section with its limits");
      return;
    }
    const ChamberSpec& c = plan_.chamber.value();
    for (const Quantity& sp : setpoints) {
      if (sp.value < c.min_temp.value || sp.value > c.max_temp.value) {
        error(sp.where, "chamber setpoint " + num(sp.value) + " degC outside the chamber range [" +
                            num(c.min_temp.value) + ", " + num(c.max_temp.value) + "] degC");
      }
    }
    if (s.ramp) {
      if (!(s.ramp->value > 0.0)) {
        error(s.ramp->where, "ramp must be positive");
      } else if (above(s.ramp->value, c.max_ramp.value)) {
        error(s.ramp->where, "ramp " + num(s.ramp->value * 60.0) +
                                 " degC/min above the chamber limit " +
                                 num(c.max_ramp.value * 60.0) + " degC/min");
      }
    }
    if (s.type == StepType::kThermal && s.mode == ThermalMode::kRamp) return;
    if (s.soak.value < 0.0) error(s.soak.where, "soak must not be negative");
    if (!s.soak_auto) return;
    const SourcePos at = s.where;
    if (!(s.settle_rate.value > 0.0)) {
      error(s.settle_rate.where.line ? s.settle_rate.where : at, "settle_rate must be positive");
    }
    if (!(s.settle_hold.value > 0.0)) {
      error(s.settle_hold.where.line ? s.settle_hold.where : at, "settle_hold must be positive");
    }
    if (s.max_soak && !(s.max_soak->value > s.settle_hold.value)) {
      error(s.max_soak->where, "max_soak " + num(s.max_soak->value) +
                                   " s must be longer than settle_hold " +
                                   num(s.settle_hold.value) +
                                   " s (the soak could never end "
                                   "settled)");
    }
  }

  // Steps executed, repeats unrolled (saturating); reports the innermost repeat that alone
  // exceeds the limit.
  long unrolledCount(const std::vector<Step>& steps, bool report) {
    const long cap = opt_.max_unrolled_steps + 1;
    long n = 0;
    for (const Step& s : steps) {
      long k = 1;
      if (s.type == StepType::kRepeat || s.type == StepType::kThermal) {
        const long body = unrolledCount(s.steps, report);
        // A thermal step runs its body once per setpoint (a ramp leg at least once).
        const long count = s.type == StepType::kRepeat ? std::max(s.count, 0)
                                                       : static_cast<long>(s.setpoints.size());
        k = (body > 0 && count > cap / body) ? cap : body * count;
        if (report && k >= cap && body < cap && !reported_unroll_) {
          error(s.count_where, "repeat count " + std::to_string(s.count) +
                                   " unrolls to more than " +
                                   std::to_string(opt_.max_unrolled_steps) + " steps");
          reported_unroll_ = true;
        }
      }
      n = std::min(cap, n + k);
    }
    return n;
  }

  // Checks that depend on where the table is: the steps as executed, in order.
  void simulate(const std::vector<Step>& steps) {
    for (const Step& s : steps) {
      switch (s.type) {
        case StepType::kMove:
          if (recording_) records_ = true;
          for (const AxisTarget& t : s.targets) {
            auto i = axisIndex(plan_.table.kind, t.axis);
            if (!i || !s.complete) continue;
            const auto ui = static_cast<size_t>(*i);
            const EffectiveLimits lim = limitsFor(plan_.table, *i);
            double delta = t.angle.value - angle_[ui];
            if (!lim.limited) {
              delta = std::remainder(delta, 2.0 * kPi);
              if (std::abs(kPi - std::abs(delta)) <= opt_.ambiguous_move_tolerance) {
                error(t.angle.where, t.axis + " " + deg(std::remainder(angle_[ui], 2.0 * kPi)) +
                                         " -> " + deg(t.angle.value) +
                                         ": a 180-degree move is ambiguous in position mode: "
                                         "use rotate with an explicit direction");
              }
            }
            angle_[ui] = lim.limited ? t.angle.value : angle_[ui] + delta;
          }
          break;
        case StepType::kRotate: {
          auto i = axisIndex(plan_.table.kind, s.axis);
          if (!i || !s.complete) break;
          const auto ui = static_cast<size_t>(*i);
          angle_[ui] += s.angle.value;
          const EffectiveLimits lim = limitsFor(plan_.table, *i);
          if (lim.limited && (angle_[ui] < lim.min_angle || angle_[ui] > lim.max_angle)) {
            error(s.angle.where, "rotation ends at " + deg(angle_[ui]) + ", outside the " + s.axis +
                                     " axis range [" + deg(lim.min_angle) + ", " +
                                     deg(lim.max_angle) + "]");
          }
          if (recording_) records_ = true;
          break;
        }
        case StepType::kRate:
        case StepType::kHold:
        case StepType::kChamber:
          if (recording_) records_ = true;
          break;
        case StepType::kRecord:
          if (s.complete) recording_ = s.record_on;
          break;
        case StepType::kRepeat:
          // A count < 1 is already an error; run the body once to spare follow-on noise.
          for (int k = 0; k < std::max(s.count, 1); ++k) simulate(s.steps);
          break;
        case StepType::kThermal:
          if (recording_ && s.mode == ThermalMode::kSoak) records_ = true;
          for (std::size_t k = 0; k < std::max<std::size_t>(s.setpoints.size(), 1); ++k) {
            simulate(s.steps);
          }
          break;
      }
    }
  }
};

void countSteps(const std::vector<Step>& steps, long mult, PlanSummary& s) {
  for (const Step& st : steps) {
    switch (st.type) {
      case StepType::kMove:
        s.moves += static_cast<int>(mult);
        break;
      case StepType::kRotate:
        s.rotates += static_cast<int>(mult);
        break;
      case StepType::kRate:
        s.rate_runs += static_cast<int>(mult);
        break;
      case StepType::kHold:
        s.holds += static_cast<int>(mult);
        break;
      case StepType::kChamber:
        s.chamber_steps += static_cast<int>(mult);
        break;
      case StepType::kRecord:
        break;
      case StepType::kRepeat:
        countSteps(st.steps, mult * std::max(st.count, 0), s);
        break;
      case StepType::kThermal: {
        const auto n = static_cast<long>(thermalSetpoints(st.setpoints, st.legs).size());
        if (st.mode == ThermalMode::kSoak) s.chamber_steps += static_cast<int>(mult * n);
        countSteps(st.steps, mult * n, s);  // ramp legs: the body at least once each
        break;
      }
    }
  }
}

std::string hms(double seconds) {
  const long total = std::lround(seconds);
  char buf[48];
  std::snprintf(buf, sizeof buf, "%ldh %02ldm %02lds", total / 3600, (total / 60) % 60, total % 60);
  return buf;
}

}  // namespace

bool validatePlan(const Plan& plan, io::Diagnostics& diag, const ValidatorOptions& options) {
  Validator v(plan, diag, options);
  return v.run();
}

std::string formatSummary(const PlanSummary& s) {
  std::string out;
  out += "plan: " + (s.name.empty() ? std::string("(unnamed)") : s.name) + " (" +
         tableKindName(s.kind) + " table)\n";
  out += "duration: " + hms(s.duration_s) + " (" + num(s.duration_s) + " s), recording " +
         hms(s.recording_s) + " (" + num(s.recording_s) + " s)\n";
  out += "steps: " + std::to_string(s.rotates) + " rotate, " + std::to_string(s.rate_runs) +
         " rate, " + std::to_string(s.moves) + " move, " + std::to_string(s.holds) + " hold, " +
         std::to_string(s.chamber_steps) + " chamber\n";
  out += "segments: " + std::to_string(s.segments) + "; temperature " + num(s.min_temp_c) + " .. " +
         num(s.max_temp_c) + " degC";
  return out;
}

namespace {

// The status of a plan with problems: how many, and that it is refused.
Status refused(std::string_view file_name, std::size_t problems) {
  return Status::Error(std::string(file_name) + ": " + std::to_string(problems) +
                       " problem(s), plan refused");
}

}  // namespace

PlanCheck checkPlanText(std::string_view text, std::string_view file_name,
                        const ValidatorOptions& options) {
  PlanCheck result;
  io::Diagnostics diag{std::string(file_name)};
  auto plan = parsePlanPartial(text, file_name, diag);
  if (plan) validatePlan(*plan, diag, options);
  if (plan && diag.ok()) {
    ExpandResult e = expand(*plan);
    if (!e.status.ok) {
      diag.error(0, 0, "expansion failed: " + e.status.message);
    } else {
      PlanSummary& s = result.summary;
      s.name = plan->name;
      s.kind = plan->table.kind;
      s.duration_s = e.motion.duration;
      for (const auto& seg : e.motion.segments) {
        if (seg.recording) s.recording_s += seg.t1 - seg.t0;
      }
      s.segments = static_cast<int>(e.motion.segments.size());
      countSteps(plan->steps, 1, s);
      if (e.motion.temperature.empty()) {
        s.min_temp_c = s.max_temp_c = e.motion.temperatureAt(0.0);
      } else {
        s.min_temp_c = s.max_temp_c = e.motion.temperature.front().temp_c;
        for (const auto& k : e.motion.temperature) {
          s.min_temp_c = std::min(s.min_temp_c, k.temp_c);
          s.max_temp_c = std::max(s.max_temp_c, k.temp_c);
        }
      }
    }
  }
  result.diagnostics = diag.items();
  result.status = diag.ok() ? Status::Ok() : refused(file_name, result.diagnostics.size());
  return result;
}

PlanCheck checkPlan(const std::string& path, const ValidatorOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    PlanCheck r;
    r.diagnostics.push_back(
        {path, 0, 0, std::string("cannot open plan file: ") + std::strerror(errno)});
    r.status = refused(path, r.diagnostics.size());
    return r;
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  return checkPlanText(ss.str(), path, options);
}

}  // namespace imubench::plans
