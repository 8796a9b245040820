// Plan file parser.
//
// GRAMMAR (TOML 1.0; every dimensioned value is a STRING with its unit, a bare number is
// refused with "missing unit"; units: see io/toml_diagnostics.h parseQuantity)
//
//   [plan]
//   name = "two_axis_12run"                # optional, free text
//   description = "..."                    # optional, free text
//   recording = "on"                       # optional, "on" | "off": state at t = 0 (default on)
//   calibration = "pipeline"               # optional: what the daemon calibrates from the run:
//                                          # "direct" | "indirect" | "pipeline" (default none)
//   direct_plan = "direct_two_axis"        # "pipeline" only, required there: the plan whose
//                                          # newest completed run gives the direct part
//
//   [table]                                # required
//   kind = "two-axis"                      # required, "two-axis" | "three-axis"
//   outer_axis_heading = "90 deg"          # two-axis only; clockwise from North; default 90 deg
//   max_rate = "30 deg/s"                  # limits for every axis...
//   max_accel = "20 deg/s^2"
//   [table.inner]                          # ...or per axis: outer | middle | inner
//   max_rate = "60 deg/s"
//   min_angle = "-95 deg"                  # both min_angle and max_angle: a LIMITED axis
//   max_angle = "95 deg"                   # (no wrap-around, no continuous rotation)
//
//   [chamber]                              # optional; required by chamber steps
//   min_temp = "-40 degC"
//   max_temp = "70 degC"
//   max_ramp = "2 degC/min"
//   initial = "20 degC"                    # optional, temperature at t = 0 (default 20 degC)
//
//   [[step]]                               # the steps, executed in file order
//   type = "move"                          # POSITION mode, absolute targets, SHORTEST way
//   outer = "90 deg"                       # one key per axis to move (outer/middle/inner)
//   inner = "0 deg"
//   rate = "10 deg/s"                      # optional (default: the axis limit)
//   accel = "5 deg/s^2"                    # optional (default: the axis limit)
//   label = "x up"                         # every step may carry a label
//
//   [[step]]
//   type = "rotate"                        # RATE mode: exact relative turn, explicit direction
//   axis = "outer"
//   angle = "180 deg"                      # signed ("-180 deg"), or unsigned with:
//   direction = "+"                        # "+" | "ccw" (positive, right-handed about the
//                                          # axis) or "-" | "cw"
//   rate = "10 deg/s"                      # optional; accel optional too
//
//   [[step]]
//   type = "rate"                          # constant-rate run (gyro scale factors)
//   axis = "inner"
//   rate = "-30 deg/s"                     # signed, or unsigned with direction = ...
//   duration = "36 s"                      # time AT the constant rate (ramps come on top)
//   accel = "10 deg/s^2"                   # optional
//
//   [[step]]
//   type = "hold"                          # static
//   duration = "60 s"
//
//   [[step]]
//   type = "chamber"                       # thermal chamber: ramp, then soak (table static)
//   setpoint = "40 degC"
//   ramp = "1 degC/min"                    # optional (default: [chamber] max_ramp)
//   soak = "60 min"                        # time held after reaching the setpoint (>= 0)
//
//   [[step]]
//   type = "chamber"                       # soak detection instead of a fixed time:
//   setpoint = "-40 degC"
//   soak = "auto"                          # over when the IMU's |dT/dt| stays below...
//   settle_rate = "0.05 degC/min"          # ...this (optional, default 0.05 degC/min)...
//   settle_hold = "10 min"                 # ...for this long (optional, default 10 min)
//   max_soak = "4 h"                       # required: then the plan goes on, the point flagged
//
//   [[step]]
//   type = "thermal"                       # the body at each chamber setpoint
//   setpoints = ["-40 degC", "20 degC", "60 degC"]
//   legs = "heat-cool"                     # optional: "heat" (rising), "cool" (falling),
//                                          # "heat-cool" (up, then back down); default as written
//   mode = "soak"                          # "soak" (default): chamber soak, then the body;
//                                          # "ramp": the chamber ramps to each setpoint and the
//                                          # body repeats while it ramps (no waiting)
//   ramp = "1 degC/min"                    # optional (default: [chamber] max_ramp)
//   soak = "auto"                          # soak mode only: as a chamber step (with
//   max_soak = "4 h"                       # settle_rate, settle_hold), or a fixed time
//   label = "cal"                          # optional prefix: "cal/T-40C/..."
//     [[step.steps]]                       # the body; labels prefixed "T-40C/" (soak; a
//     type = "hold"                        # revisited setpoint "T20C#2/") or
//     duration = "2 min"                   # "ramp1/rep03/" (ramp)
//
//   [[step]]
//   type = "record"                        # recording on/off for what follows
//   state = "off"                          # "on" | "off"
//
//   [[step]]
//   type = "repeat"                        # repeat the nested steps
//   count = 8                              # integer >= 1 (dimensionless: a bare number)
//   label = "heading"
//     [[step.steps]]                       # nested steps ([[step.steps.steps]] nests deeper)
//     type = "hold"
//     duration = "15 min"
//     [[step.steps]]
//     type = "rotate"
//     axis = "inner"
//     angle = "45 deg"
//
// Errors found here (all of them, with file:line:column): bad TOML, missing units, wrong unit
// dimension, unknown keys (with a "did you mean" when close), unknown step types, wrong value
// types, missing required keys. Semantic checks are in plans/validator.cpp.
#include "plans/plan.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <span>
#include <sstream>
#include <utility>

#include "nav/rotation.h"

namespace imubench::plans {

using calib::TableKind;

const char* stepTypeName(StepType t) {
  switch (t) {
    case StepType::kMove:
      return "move";
    case StepType::kRotate:
      return "rotate";
    case StepType::kRate:
      return "rate";
    case StepType::kHold:
      return "hold";
    case StepType::kChamber:
      return "chamber";
    case StepType::kRecord:
      return "record";
    case StepType::kRepeat:
      return "repeat";
    case StepType::kThermal:
      return "thermal";
  }
  return "hold";
}

std::vector<std::string_view> axisNames(TableKind kind) {
  if (kind == TableKind::kTwoAxis) return {"outer", "inner"};
  return {"outer", "middle", "inner"};
}

std::optional<int> axisIndex(TableKind kind, std::string_view name) {
  const auto names = axisNames(kind);
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return std::nullopt;
}

const char* tableKindName(TableKind kind) {
  return kind == TableKind::kTwoAxis ? "two-axis" : "three-axis";
}

const char* calibrationMethodName(CalibrationMethod m) {
  switch (m) {
    case CalibrationMethod::kNone:
      return "none";
    case CalibrationMethod::kDirect:
      return "direct";
    case CalibrationMethod::kIndirect:
      return "indirect";
    case CalibrationMethod::kPipeline:
      return "pipeline";
  }
  return "none";
}

std::vector<double> thermalSetpoints(const std::vector<Quantity>& written, ThermalLegs legs) {
  std::vector<double> v;
  for (const Quantity& q : written) v.push_back(q.value);
  if (legs == ThermalLegs::kAsWritten) return v;
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  if (legs == ThermalLegs::kCool) std::reverse(v.begin(), v.end());
  if (legs == ThermalLegs::kHeatCool) {
    // Up through every setpoint, then back down through them (the top visited once).
    for (std::size_t i = v.size(); i-- > 1;) v.push_back(v[i - 1]);
  }
  return v;
}

EffectiveLimits limitsFor(const TableSpec& table, int axis) {
  EffectiveLimits lim;
  if (table.max_rate) lim.max_rate = table.max_rate->value;
  if (table.max_accel) lim.max_accel = table.max_accel->value;
  const auto names = axisNames(table.kind);
  if (axis < 0 || axis >= static_cast<int>(names.size())) return lim;
  for (const auto& a : table.axes) {
    if (a.axis != names[static_cast<size_t>(axis)]) continue;
    if (a.max_rate) lim.max_rate = a.max_rate->value;
    if (a.max_accel) lim.max_accel = a.max_accel->value;
    if (a.min_angle && a.max_angle) {
      lim.limited = true;
      lim.min_angle = a.min_angle->value;
      lim.max_angle = a.max_angle->value;
    }
  }
  return lim;
}

namespace {

constexpr std::string_view kTypes[] = {"move",    "rotate", "rate",   "hold",
                                       "chamber", "record", "repeat", "thermal"};

constexpr std::string_view kKinds[] = {"two-axis", "three-axis"};

constexpr int kMaxNesting = 16;  // repeat nesting deeper than this is surely a mistake

SourcePos posOf(const toml::source_region& r) {
  return {static_cast<int>(r.begin.line), static_cast<int>(r.begin.column)};
}

// Position of a key (not its value) in a table.
SourcePos keyPos(const toml::table& t, std::string_view key) {
  for (auto&& [k, v] : t) {
    (void)v;
    if (k.str() == key) return posOf(k.source());
  }
  return posOf(t.source());
}

size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// " (did you mean \"x\"?)" when a candidate is close, else "".
std::string didYouMean(std::string_view word, std::span<const std::string_view> options) {
  std::string_view best;
  size_t best_d = 3;  // at most two edits
  for (auto o : options) {
    const size_t d = editDistance(word, o);
    if (d < best_d) {
      best_d = d;
      best = o;
    }
  }
  return best.empty() ? std::string() : " (did you mean \"" + std::string(best) + "\"?)";
}

// The value `word` names among `choices` (keyword, value), or nullopt when it names none.
template <class E>
std::optional<E> keywordValue(std::string_view word,
                              std::initializer_list<std::pair<std::string_view, E>> choices) {
  for (const auto& [keyword, value] : choices) {
    if (keyword == word) return value;
  }
  return std::nullopt;
}

std::string joinQuoted(std::span<const std::string_view> options) {
  std::string s;
  for (auto o : options) s += (s.empty() ? "\"" : ", \"") + std::string(o) + "\"";
  return s;
}

class Parser {
 public:
  explicit Parser(io::Diagnostics& diag) : diag_(diag) {}

  Plan parse(const toml::table& root, std::string_view file_name) {
    Plan plan;
    plan.file = std::string(file_name);
    checkKeys(root, {"plan", "table", "chamber", "step"}, "the top level");
    if (const auto* t = subTable(root, "plan", false)) parsePlanTable(*t, plan);
    if (const auto* t = subTable(root, "table", true)) parseTable(*t, plan.table);
    if (const auto* t = subTable(root, "chamber", false)) plan.chamber = parseChamber(*t);
    if (const toml::node* n = root.get("step")) {
      if (const auto* arr = n->as_array()) {
        parseSteps(*arr, plan.steps, 0);
      } else {
        diag_.error(n->source(),
                    "\"step\" must be an array of tables: write each step as [[step]]");
      }
    } else {
      diag_.error(1, 1, "the plan has no steps: add [[step]] tables");
    }
    return plan;
  }

 private:
  io::Diagnostics& diag_;

  const toml::table* subTable(const toml::table& t, std::string_view key, bool required) {
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) diag_.error(1, 1, "missing required [" + std::string(key) + "] table");
      return nullptr;
    }
    if (const auto* tt = n->as_table()) return tt;
    diag_.error(n->source(),
                "\"" + std::string(key) + "\" must be a table ([" + std::string(key) + "])");
    return nullptr;
  }

  void checkKeys(const toml::table& t, std::initializer_list<std::string_view> allowed,
                 std::string_view context) {
    for (auto&& [k, v] : t) {
      (void)v;
      if (std::find(allowed.begin(), allowed.end(), k.str()) != allowed.end()) continue;
      const std::span<const std::string_view> options(allowed.begin(), allowed.size());
      diag_.error(k.source(), "unknown key \"" + std::string(k.str()) + "\" in " +
                                  std::string(context) + didYouMean(k.str(), options) +
                                  "; allowed: " + joinQuoted(options));
    }
  }

  std::optional<Quantity> quantity(const toml::table& t, std::string_view key, io::Dimension dim,
                                   bool required) {
    auto v = io::quantityField(t, key, dim, diag_, required);
    if (!v) return std::nullopt;
    return Quantity{*v, posOf(t.get(key)->source())};
  }

  std::optional<std::string> text(const toml::table& t, std::string_view key, bool required) {
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) {
        diag_.error(t.source(), "missing required key \"" + std::string(key) + "\"");
      }
      return std::nullopt;
    }
    if (const auto* s = n->as_string()) return s->get();
    diag_.error(n->source(), "\"" + std::string(key) + "\" must be a string");
    return std::nullopt;
  }

  // "on"/"off" (or true/false).
  std::optional<bool> onOff(const toml::table& t, std::string_view key, bool required) {
    const toml::node* n = t.get(key);
    if (!n && !required) return std::nullopt;
    if (n && n->is_boolean()) return n->value_or(false);
    auto s = text(t, key, required);
    if (!s) return std::nullopt;
    if (*s == "on") return true;
    if (*s == "off") return false;
    diag_.error(n->source(),
                "\"" + std::string(key) + "\" must be \"on\" or \"off\", got \"" + *s + "\"");
    return std::nullopt;
  }

  // Applies an optional direction = "+"|"ccw"|"-"|"cw" to a quantity that is then unsigned.
  void applyDirection(const toml::table& t, std::optional<Quantity>& q, std::string_view what) {
    const toml::node* n = t.get("direction");
    if (!n) return;
    auto dir = text(t, "direction", true);
    if (!dir) return;
    double sign = 0.0;
    if (*dir == "+" || *dir == "ccw") sign = 1.0;
    if (*dir == "-" || *dir == "cw") sign = -1.0;
    if (sign == 0.0) {
      diag_.error(n->source(),
                  "direction must be \"+\", \"ccw\", \"-\" or \"cw\", got \"" + *dir + "\"");
      return;
    }
    if (!q) return;
    if (q->value < 0.0) {
      diag_.error(t.get(what)->source(),
                  "\"" + std::string(what) +
                      "\" must be unsigned when direction is given (the sign comes from "
                      "direction)");
      return;
    }
    q->value *= sign;
  }

  void parsePlanTable(const toml::table& t, Plan& plan) {
    plan.plan_where = posOf(t.source());
    checkKeys(t, {"name", "description", "recording", "calibration", "direct_plan"}, "[plan]");
    if (auto s = text(t, "name", false)) plan.name = *s;
    if (auto s = text(t, "description", false)) plan.description = *s;
    if (auto r = onOff(t, "recording", false)) plan.recording_at_start = *r;
    parseCalibration(t, plan);
  }

  // [plan] calibration and direct_plan (a pipeline names its direct plan; nothing else may).
  void parseCalibration(const toml::table& t, Plan& plan) {
    if (auto c = text(t, "calibration", false)) {
      if (auto m =
              keywordValue<CalibrationMethod>(*c, {{"direct", CalibrationMethod::kDirect},
                                                   {"indirect", CalibrationMethod::kIndirect},
                                                   {"pipeline", CalibrationMethod::kPipeline}})) {
        plan.calibration = *m;
      } else {
        diag_.error(t.get("calibration")->source(),
                    "unknown calibration \"" + *c +
                        "\": expected \"direct\", \"indirect\" or \"pipeline\"");
      }
    }
    if (auto d = text(t, "direct_plan", false)) plan.direct_plan = *d;
    const bool pipeline = plan.calibration == CalibrationMethod::kPipeline;
    if (pipeline && plan.direct_plan.empty() && !t.get("direct_plan")) {
      diag_.error(t.source(),
                  "calibration = \"pipeline\" needs direct_plan (the plan whose completed run "
                  "gives the direct calibration)");
    }
    if (!pipeline && t.get("direct_plan")) {
      diag_.error(t.get("direct_plan")->source(),
                  "direct_plan applies to calibration = \"pipeline\" only");
    }
  }

  void parseTable(const toml::table& t, TableSpec& table) {
    table.where = posOf(t.source());
    checkKeys(t,
              {"kind", "outer_axis_heading", "max_rate", "max_accel", "outer", "middle", "inner"},
              "[table]");
    if (auto k = text(t, "kind", true)) {
      if (auto kind = keywordValue<TableKind>(
              *k, {{"two-axis", TableKind::kTwoAxis}, {"three-axis", TableKind::kThreeAxis}})) {
        table.kind = *kind;
      } else {
        diag_.error(t.get("kind")->source(), "unknown table kind \"" + *k +
                                                 "\": expected \"two-axis\" or \"three-axis\"" +
                                                 didYouMean(*k, kKinds));
      }
    }
    if (auto h = quantity(t, "outer_axis_heading", io::Dimension::kAngle, false)) {
      if (table.kind != TableKind::kTwoAxis) {
        diag_.error(t.get("outer_axis_heading")->source(),
                    "outer_axis_heading applies to two-axis tables only (a three-axis table's "
                    "outer axis is vertical)");
      }
      table.outer_axis_heading = h->value;
    }
    table.max_rate = quantity(t, "max_rate", io::Dimension::kRate, false);
    table.max_accel = quantity(t, "max_accel", io::Dimension::kAngularAccel, false);
    for (std::string_view axis : {"outer", "middle", "inner"}) {
      const toml::node* n = t.get(axis);
      if (!n) continue;
      const auto* at = n->as_table();
      if (!at) {
        diag_.error(n->source(), "\"" + std::string(axis) +
                                     "\" in [table] must be a table ([table." + std::string(axis) +
                                     "])");
        continue;
      }
      const std::string ctx = "[table." + std::string(axis) + "]";
      checkKeys(*at, {"max_rate", "max_accel", "min_angle", "max_angle"}, ctx);
      AxisLimits lim;
      lim.axis = std::string(axis);
      lim.where = posOf(at->source());
      lim.max_rate = quantity(*at, "max_rate", io::Dimension::kRate, false);
      lim.max_accel = quantity(*at, "max_accel", io::Dimension::kAngularAccel, false);
      lim.min_angle = quantity(*at, "min_angle", io::Dimension::kAngle, false);
      lim.max_angle = quantity(*at, "max_angle", io::Dimension::kAngle, false);
      if (static_cast<bool>(at->get("min_angle")) != static_cast<bool>(at->get("max_angle"))) {
        diag_.error(at->source(), ctx +
                                      ": give both min_angle and max_angle (a limited axis) "
                                      "or neither (a continuous axis)");
      }
      table.axes.push_back(std::move(lim));
    }
  }

  ChamberSpec parseChamber(const toml::table& t) {
    ChamberSpec c;
    c.where = posOf(t.source());
    checkKeys(t, {"min_temp", "max_temp", "max_ramp", "initial"}, "[chamber]");
    if (auto q = quantity(t, "min_temp", io::Dimension::kTemperature, true)) c.min_temp = *q;
    if (auto q = quantity(t, "max_temp", io::Dimension::kTemperature, true)) c.max_temp = *q;
    if (auto q = quantity(t, "max_ramp", io::Dimension::kTemperatureRate, true)) c.max_ramp = *q;
    c.initial = {20.0, {}};
    if (auto q = quantity(t, "initial", io::Dimension::kTemperature, false)) c.initial = *q;
    return c;
  }

  void parseSteps(const toml::array& arr, std::vector<Step>& out, int depth) {
    for (const toml::node& n : arr) {
      const auto* t = n.as_table();
      if (!t) {
        diag_.error(n.source(), "a step must be a table ([[step]] or { type = ... })");
        continue;
      }
      out.push_back(parseStep(*t, depth));
    }
  }

  Step parseStep(const toml::table& t, int depth) {
    Step s;
    s.where = posOf(t.source());
    const size_t errors_before = diag_.items().size();
    if (auto l = text(t, "label", false)) s.label = *l;
    const toml::node* type_node = t.get("type");
    auto type = text(t, "type", false);
    if (!type_node) {
      diag_.error(t.source(), "step has no \"type\": one of " + joinQuoted(kTypes));
      s.complete = false;
      return s;
    }
    if (!type) {
      s.complete = false;
      return s;
    }
    if (*type == "move") {
      s.type = StepType::kMove;
      checkKeys(t, {"type", "label", "outer", "middle", "inner", "rate", "accel"}, "a move step");
      for (std::string_view axis : {"outer", "middle", "inner"}) {
        const toml::node* an = t.get(axis);
        if (!an) continue;
        if (auto q = quantity(t, axis, io::Dimension::kAngle, true)) {
          s.targets.push_back({std::string(axis), keyPos(t, axis), *q});
        }
      }
      if (!t.get("outer") && !t.get("middle") && !t.get("inner")) {
        diag_.error(t.source(),
                    "a move step needs at least one axis target, e.g. outer = \"90 deg\"");
      }
      s.rate = quantity(t, "rate", io::Dimension::kRate, false);
      s.accel = quantity(t, "accel", io::Dimension::kAngularAccel, false);
    } else if (*type == "rotate") {
      s.type = StepType::kRotate;
      checkKeys(t, {"type", "label", "axis", "angle", "direction", "rate", "accel"},
                "a rotate step");
      parseAxis(t, s);
      auto angle = quantity(t, "angle", io::Dimension::kAngle, true);
      applyDirection(t, angle, "angle");
      if (angle) s.angle = *angle;
      s.rate = quantity(t, "rate", io::Dimension::kRate, false);
      s.accel = quantity(t, "accel", io::Dimension::kAngularAccel, false);
    } else if (*type == "rate") {
      s.type = StepType::kRate;
      checkKeys(t, {"type", "label", "axis", "rate", "direction", "duration", "accel"},
                "a rate step");
      parseAxis(t, s);
      s.rate = quantity(t, "rate", io::Dimension::kRate, true);
      applyDirection(t, s.rate, "rate");
      if (auto d = quantity(t, "duration", io::Dimension::kTime, true)) s.duration = *d;
      s.accel = quantity(t, "accel", io::Dimension::kAngularAccel, false);
    } else if (*type == "hold") {
      s.type = StepType::kHold;
      checkKeys(t, {"type", "label", "duration"}, "a hold step");
      if (auto d = quantity(t, "duration", io::Dimension::kTime, true)) s.duration = *d;
    } else if (*type == "chamber") {
      s.type = StepType::kChamber;
      checkKeys(
          t,
          {"type", "label", "setpoint", "ramp", "soak", "settle_rate", "settle_hold", "max_soak"},
          "a chamber step");
      if (auto q = quantity(t, "setpoint", io::Dimension::kTemperature, true)) s.setpoint = *q;
      s.ramp = quantity(t, "ramp", io::Dimension::kTemperatureRate, false);
      parseSoak(t, s);
    } else if (*type == "thermal") {
      s.type = StepType::kThermal;
      checkKeys(t,
                {"type", "label", "setpoints", "legs", "mode", "ramp", "soak", "settle_rate",
                 "settle_hold", "max_soak", "steps"},
                "a thermal step");
      parseThermal(t, s, depth);
    } else if (*type == "record") {
      s.type = StepType::kRecord;
      checkKeys(t, {"type", "label", "state"}, "a record step");
      if (auto r = onOff(t, "state", true)) s.record_on = *r;
    } else if (*type == "repeat") {
      s.type = StepType::kRepeat;
      checkKeys(t, {"type", "label", "count", "steps"}, "a repeat step");
      parseRepeat(t, s, depth);
    } else {
      diag_.error(type_node->source(), "unknown step type \"" + *type + "\"" +
                                           didYouMean(*type, kTypes) + "; expected one of " +
                                           joinQuoted(kTypes));
      s.complete = false;
      return s;
    }
    // Errors inside nested steps are their own; count only this step's fields.
    size_t nested_errors = 0;
    if (s.type == StepType::kRepeat || s.type == StepType::kThermal) nested_errors = nested_errors_;
    s.complete = diag_.items().size() - nested_errors == errors_before;
    return s;
  }

  void parseAxis(const toml::table& t, Step& s) {
    if (auto a = text(t, "axis", true)) {
      s.axis = *a;
      s.axis_where = posOf(t.get("axis")->source());
    }
  }

  // soak = "<time>" | "auto", and with "auto" settle_rate, settle_hold, max_soak (required).
  void parseSoak(const toml::table& t, Step& s) {
    const toml::node* n = t.get("soak");
    const auto* str = n ? n->as_string() : nullptr;
    s.soak_auto = str && str->get() == "auto";
    if (!s.soak_auto) {
      if (auto q = quantity(t, "soak", io::Dimension::kTime, true)) s.soak = *q;
      for (std::string_view key : {"settle_rate", "settle_hold", "max_soak"}) {
        if (const toml::node* k = t.get(key)) {
          diag_.error(k->source(), "\"" + std::string(key) +
                                       "\" applies to soak = \"auto\" only (a fixed soak ends "
                                       "after its time)");
        }
      }
      return;
    }
    s.soak = {0.0, posOf(n->source())};
    if (auto q = quantity(t, "settle_rate", io::Dimension::kTemperatureRate, false)) {
      s.settle_rate = *q;
    }
    if (auto q = quantity(t, "settle_hold", io::Dimension::kTime, false)) s.settle_hold = *q;
    s.max_soak = quantity(t, "max_soak", io::Dimension::kTime, false);
    if (!t.get("max_soak")) {
      diag_.error(t.source(),
                  "soak = \"auto\" needs max_soak (after it the plan goes on and the point is "
                  "flagged: a soak must never wait forever)");
    }
  }

  // The nested steps of a repeat or thermal step into s.steps; nested errors counted apart.
  void parseBody(const toml::table& t, Step& s, int depth, std::string_view what) {
    const toml::node* sn = t.get("steps");
    if (!sn) {
      diag_.error(t.source(),
                  "a " + std::string(what) + " step needs nested steps: add [[step.steps]] tables");
      return;
    }
    const auto* arr = sn->as_array();
    if (!arr) {
      diag_.error(sn->source(), "\"steps\" must be an array of tables ([[step.steps]])");
      return;
    }
    if (depth + 1 > kMaxNesting) {
      diag_.error(sn->source(), "steps nested more than " + std::to_string(kMaxNesting) + " deep");
      return;
    }
    if (arr->empty()) {
      diag_.error(sn->source(), "a " + std::string(what) + " step needs at least one nested step");
    }
    const size_t before = diag_.items().size();
    parseSteps(*arr, s.steps, depth + 1);
    nested_errors_ = diag_.items().size() - before;
  }

  void parseThermal(const toml::table& t, Step& s, int depth) {
    nested_errors_ = 0;
    if (const toml::node* n = t.get("setpoints"); !n) {
      diag_.error(t.source(),
                  "a thermal step needs setpoints, e.g. setpoints = [\"-40 degC\", "
                  "\"20 degC\", \"60 degC\"]");
    } else if (const auto* arr = n->as_array()) {
      s.setpoints_where = posOf(n->source());
      if (arr->empty()) diag_.error(n->source(), "setpoints is empty: give at least one");
      for (const toml::node& e : *arr) {
        const auto* str = e.as_string();
        std::string why;
        const auto v =
            str ? io::parseQuantity(str->get(), io::Dimension::kTemperature, &why) : std::nullopt;
        if (!str) why = "each setpoint must be a string with its unit, e.g. \"-40 degC\"";
        if (v) {
          s.setpoints.push_back({*v, posOf(e.source())});
        } else {
          diag_.error(e.source(), "setpoint: " + why);
        }
      }
    } else {
      diag_.error(n->source(), "setpoints must be an array, e.g. [\"-40 degC\", \"60 degC\"]");
    }
    if (auto l = text(t, "legs", false)) {
      if (auto legs = keywordValue<ThermalLegs>(*l, {{"heat", ThermalLegs::kHeat},
                                                     {"cool", ThermalLegs::kCool},
                                                     {"heat-cool", ThermalLegs::kHeatCool}})) {
        s.legs = *legs;
      } else {
        diag_.error(t.get("legs")->source(),
                    "legs must be \"heat\", \"cool\" or "
                    "\"heat-cool\", got \"" +
                        *l + "\"");
      }
    }
    if (auto m = text(t, "mode", false)) {
      if (*m == "ramp") {
        s.mode = ThermalMode::kRamp;
      } else if (*m != "soak") {
        diag_.error(t.get("mode")->source(),
                    "mode must be \"soak\" or \"ramp\", got \"" + *m + "\"");
      }
    }
    s.ramp = quantity(t, "ramp", io::Dimension::kTemperatureRate, false);
    if (s.mode == ThermalMode::kSoak) {
      parseSoak(t, s);
    } else {
      for (std::string_view key : {"soak", "settle_rate", "settle_hold", "max_soak"}) {
        if (const toml::node* k = t.get(key)) {
          diag_.error(k->source(), "\"" + std::string(key) +
                                       "\" applies to mode = \"soak\" only (a ramp does not "
                                       "wait for the chamber)");
        }
      }
    }
    parseBody(t, s, depth, "thermal");
  }

  void parseRepeat(const toml::table& t, Step& s, int depth) {
    nested_errors_ = 0;
    const toml::node* cn = t.get("count");
    if (!cn) {
      diag_.error(t.source(), "missing required key \"count\" (an integer >= 1)");
    } else if (const auto* ci = cn->as_integer()) {
      const int64_t c = ci->get();
      s.count = c > 1000000000 ? 1000000000 : (c < -1000000000 ? -1000000000 : static_cast<int>(c));
      s.count_where = posOf(cn->source());
    } else {
      diag_.error(cn->source(), "\"count\" must be an integer, e.g. count = 3");
    }
    parseBody(t, s, depth, "repeat");
  }

  size_t nested_errors_ = 0;
};

std::optional<Plan> parseImpl(std::string_view text, std::string_view file_name,
                              io::Diagnostics& diag) {
  auto root = io::parseToml(text, diag);
  if (!root) return std::nullopt;
  Parser p(diag);
  return p.parse(*root, file_name);
}

}  // namespace

std::optional<Plan> parsePlanPartial(std::string_view text, std::string_view file_name,
                                     io::Diagnostics& diag) {
  return parseImpl(text, file_name, diag);
}

std::optional<Plan> parsePlan(std::string_view text, std::string_view file_name,
                              io::Diagnostics& diag) {
  const size_t before = diag.items().size();
  auto plan = parseImpl(text, file_name, diag);
  if (diag.items().size() != before) return std::nullopt;
  return plan;
}

namespace {
std::optional<std::string> readFile(const std::string& path, io::Diagnostics& diag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    diag.error(0, 0, std::string("cannot open plan file: ") + std::strerror(errno));
    return std::nullopt;
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) {
    diag.error(0, 0, "error reading plan file");
    return std::nullopt;
  }
  return ss.str();
}
}  // namespace

std::optional<Plan> loadPlanFile(const std::string& path, io::Diagnostics& diag) {
  auto text = readFile(path, diag);
  if (!text) return std::nullopt;
  return parsePlan(*text, path, diag);
}

}  // namespace imubench::plans
