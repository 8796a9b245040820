// Plan files: what an operator or a lab script asks the bench to do, as a parsed value.
//
// The TOML grammar (with examples) is documented above the parser in plans/plan.cpp and in
// docs/plan-format.md. No toml++ types leak out of this header's values: a Plan is plain data
// in SI units (rad, rad/s, rad/s^2, s, degC, degC/s), each value remembering where in the file
// it was written so the validator can name file:line:column.
//
// Typical use:
//   Diagnostics diag("plan.toml");
//   auto plan = loadPlanFile("plan.toml", diag);        // syntax, units, keys, step shapes
//   if (plan && validatePlan(*plan, diag)) { ... }      // plans/validator.h: limits, 180 deg...
//   if (!diag.ok()) report(diag.str());
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/model/motion.h"
#include "io/toml_diagnostics.h"

namespace imubench::plans {

// Where a value was written (1-based; 0 when unknown, e.g. a default).
struct SourcePos {
  int line = 0;
  int column = 0;
};

// A dimensioned value converted to SI, with its position in the file.
struct Quantity {
  double value = 0.0;
  SourcePos where;
};

// Per-axis limits as written in [table.<axis>] (overrides of the global ones in [table]).
struct AxisLimits {
  std::string axis;  // as written: "outer", "middle", "inner" (checked by the validator)
  SourcePos where;
  std::optional<Quantity> max_rate;   // rad/s
  std::optional<Quantity> max_accel;  // rad/s^2
  std::optional<Quantity> min_angle;  // rad; both set: the axis is limited (not continuous)
  std::optional<Quantity> max_angle;  // rad
};

struct TableSpec {
  calib::TableKind kind = calib::TableKind::kTwoAxis;
  SourcePos where;                                      // the [table] header
  double outer_axis_heading = 0.5 * 3.141592653589793;  // rad, clockwise from North
  std::optional<Quantity> max_rate;                     // rad/s, all axes unless overridden
  std::optional<Quantity> max_accel;                    // rad/s^2, all axes unless overridden
  std::vector<AxisLimits> axes;                         // overrides
};

// Effective limits of one axis (global value unless overridden). A limit that is not given
// anywhere is nullopt; the validator requires rate and accel limits for every axis used.
struct EffectiveLimits {
  std::optional<double> max_rate;   // rad/s
  std::optional<double> max_accel;  // rad/s^2
  bool limited = false;             // position range given
  double min_angle = 0.0;           // rad (when limited)
  double max_angle = 0.0;           // rad (when limited)
};
EffectiveLimits limitsFor(const TableSpec& table, int axis);

struct ChamberSpec {
  SourcePos where;    // the [chamber] header
  Quantity min_temp;  // degC
  Quantity max_temp;  // degC
  Quantity max_ramp;  // degC/s
  Quantity initial;   // degC at t = 0 (default 20 degC: lab ambient)
};

enum class StepType { kMove, kRotate, kRate, kHold, kChamber, kRecord, kRepeat, kThermal };
const char* stepTypeName(StepType t);  // "move", "rotate", ...

// The order of a thermal step's setpoints: as written, or sorted into a heating leg (rising),
// a cooling leg (falling), or heating then cooling back (both hysteresis branches).
enum class ThermalLegs { kAsWritten, kHeat, kCool, kHeatCool };
// soak: the chamber soaks at each setpoint, then the body runs; ramp: the chamber is told to
// go to each setpoint at the ramp rate and the body repeats while it ramps (Niu et al., Sensors
// 13(9):12192).
enum class ThermalMode { kSoak, kRamp };

// The setpoints of a thermal step in the order its legs visit them (degC). Pure.
std::vector<double> thermalSetpoints(const std::vector<Quantity>& written, ThermalLegs legs);

struct AxisTarget {
  std::string axis;  // as written
  SourcePos axis_where;
  Quantity angle;  // rad, absolute table angle
};

struct Step {
  StepType type = StepType::kHold;
  SourcePos where;    // the step's table ([[step]] header or inline table)
  std::string label;  // empty: none given
  // False when the parser already reported an error inside this step; the validator then
  // skips its semantic checks (no follow-on noise) and expand() refuses the plan.
  bool complete = true;

  // move: absolute targets, shortest way. rotate: relative turn. rate: constant-rate run.
  std::vector<AxisTarget> targets;  // move
  std::string axis;                 // rotate, rate
  SourcePos axis_where;
  Quantity angle;                 // rotate: signed relative angle (direction applied), rad
  std::optional<Quantity> rate;   // move/rotate: magnitude (default: axis limit);
                                  // rate step: signed, required (rad/s)
  std::optional<Quantity> accel;  // move/rotate/rate: magnitude (default: axis limit)
  Quantity duration;              // hold; rate (time at constant rate, ramps excluded), s

  Quantity setpoint;             // chamber, degC
  std::optional<Quantity> ramp;  // chamber ramp rate, degC/s (default: [chamber] max_ramp)
  Quantity soak;                 // chamber: time held at setpoint after the ramp, s (>= 0)
  // chamber / thermal soak = "auto": the soak ends when the IMU's temperature rate stayed below
  // settle_rate for settle_hold (defaults below when not written), at most max_soak (required)
  // after the chamber command.
  bool soak_auto = false;
  Quantity settle_rate{0.05 / 60.0, {}};  // degC/s (default 0.05 degC/min)
  Quantity settle_hold{600.0, {}};        // s (default 10 min)
  std::optional<Quantity> max_soak;       // s

  // thermal: the body (`steps`) once per setpoint, in leg order.
  std::vector<Quantity> setpoints;  // degC, as written
  SourcePos setpoints_where;
  ThermalLegs legs = ThermalLegs::kAsWritten;
  ThermalMode mode = ThermalMode::kSoak;

  bool record_on = true;  // record

  int count = 1;  // repeat
  SourcePos count_where;
  std::vector<Step> steps;  // repeat and thermal body
};

// The calibration a plan's recording feeds ([plan] calibration): what the daemon computes
// online during the run and in full at its end (daemon/online_engine.h).
enum class CalibrationMethod {
  kNone,      // no calibration (key absent): the run only records
  kDirect,    // direct calibration of this run (calib/direct_calibration.h)
  kIndirect,  // navigation-based calibration of this run alone
              // (calib/indirect/indirect_calibration.h)
  kPipeline,  // the production pipeline (calib/indirect/bench_calibration.h): this run's navigation
              // refinement with the direct part from a completed run of plan `direct_plan`
};
const char* calibrationMethodName(CalibrationMethod m);  // "none" | "direct" | ...

struct Plan {
  std::string file;  // file name used in diagnostics
  std::string name;
  std::string description;
  CalibrationMethod calibration = CalibrationMethod::kNone;
  // kPipeline: the name of the plan whose newest completed run (same IMU serial, same bench)
  // gives the direct part.
  std::string direct_plan;
  SourcePos plan_where;            // the [plan] header
  bool recording_at_start = true;  // [plan] recording = "on" | "off"
  TableSpec table;
  std::optional<ChamberSpec> chamber;
  std::vector<Step> steps;
};

// Axis names of a table kind, in the axis order of calib/model/motion.h.
std::vector<std::string_view> axisNames(calib::TableKind kind);
std::optional<int> axisIndex(calib::TableKind kind, std::string_view name);
const char* tableKindName(calib::TableKind kind);  // "two-axis" | "three-axis"

// Parses plan text. Reports every syntax / shape error (bad TOML, missing units, wrong unit
// dimension, unknown keys and step types, wrong value types) into diag and returns nullopt
// if there was any. Semantic checks (limits, axes, 180-degree moves...) are validatePlan's.
std::optional<Plan> parsePlan(std::string_view text, std::string_view file_name,
                              io::Diagnostics& diag);

// As parsePlan, but returns the plan even when some fields had errors (those steps are
// marked complete = false), so a checker can run the validator too and report ALL errors at
// once. nullopt only when the text is not TOML at all.
std::optional<Plan> parsePlanPartial(std::string_view text, std::string_view file_name,
                                     io::Diagnostics& diag);

// Reads a plan file (an unreadable file is a diagnostic, not an exception).
std::optional<Plan> loadPlanFile(const std::string& path, io::Diagnostics& diag);

}  // namespace imubench::plans
