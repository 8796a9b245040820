// The experiment that settles what explain could not (issue 27 item 1, `imubench explain
// --propose-plan`): for every group explain reports unseparable and every accepted effect whose
// sigma is above the requested precision, the shortest plan found of generated motion blocks
// under which the groups are separable and the effects precise. Pure: values in, values out.
//
// How (docs/explain.md "Proposing the separating plan"):
//   - Candidate blocks from the physics of what separates effects on a table (ProposedBlock):
//     runs about one axis with another axis at several angles, holds at eight angles of one
//     axis, runs at two rates, 180 deg reversals, each about every axis of the recording's
//     table kind and within the bench limits. A calibration base (holds with each axis up and
//     down, a turn each way about every axis) starts the plan, so its recording can be
//     calibrated and explained alone.
//   - Each block is expanded by the one plan expander (the caller's ProposalExpander: plans/),
//     simulated without noise (calib/simulator.h) at the recording's baseline coefficients,
//     binned like the recording (calib/explain/explain_model.h) and whitened with the recording's
//     own noise floor; its regressors are those of the SAME forward model explain uses
//     (ExplainEvaluator), so the information of a plan is the sum of its blocks'.
//   - A group's separation is explain's own gate (calib/explain/explain.cpp holdSharedWith): the
//     principal angle between the second effect's columns and the first's, both projected off
//     the baseline's; separable above acos(ExplainOptions::unseparable_cos). Predicted sigmas
//     are the inverse information's diagonal (baseline coefficients and the groups' effects).
//   - Greedy: the block that removes most of the plan's deficit (angles short of the limit,
//     sigmas above the precision) per second is added until no deficit is left, no block
//     helps, or none fits in max_duration_s; groups left short are reported unresolved.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/explain/explain.h"
#include "calib/model/motion.h"

namespace imubench::calib {

struct ProposedStep {
  enum class Kind { kMove, kHold, kRotate };
  Kind kind = Kind::kHold;
  std::vector<double> angles_rad;  // move: absolute target of every axis (axis order)
  int axis = 0;                    // rotate: the axis turned
  double angle_rad = 0.0;          // rotate: signed turn
  double rate_rad_s = 0.0;         // rotate: cruise rate (magnitude)
  double duration_s = 0.0;         // hold
  std::string label;
};

struct ProposedBlock {
  std::string purpose;  // what it is for (the plan's comment above it)
  std::vector<ProposedStep> steps;
  double duration_s = 0.0;  // of its expansion (ProposalExpander), s
};

// A plan as values (io/plan_writer.h writes it as plan TOML).
struct ProposedPlan {
  std::string name = "explain_proposal";
  std::string description;
  TableKind kind = TableKind::kTwoAxis;
  double max_rate_rad_s = 0.0;  // [table] limits the plan asks for
  double max_accel_rad_s2 = 0.0;
  std::vector<ProposedBlock> blocks;
};

// The bench's limits. Defaults: the virtual bench's (daemon/benches/virtual-bench.toml: 30
// deg/s, 10 deg/s^2, continuous axes), the limits of the bundled plans.
struct ProposeLimits {
  double max_rate_rad_s = 30.0 * kPi / 180.0;
  double max_accel_rad_s2 = 10.0 * kPi / 180.0;
};

// The plan expander (plans/ parse + validate + expand of the written plan): Motion of a plan,
// or a failed status saying why the plan is not fit to run.
using ProposalExpander = std::function<Result<Motion>(const ProposedPlan&)>;

struct ProposeOptions {
  ProposeLimits limits;
  // An accepted effect is to be measured to this fraction of its size (sigma / |value|, the
  // norm over its parameters): 0.1 is the "within 10 %" and a 10-sigma detection.
  double relative_precision = 0.1;
  // Longest plan, s: two hours is a bench session; a group that needs more stays unresolved.
  double max_duration_s = 7200.0;
  // Static holds of the generated blocks, s: long enough for a mean at the noise floor's
  // white-noise level and above the noise floor's shortest Allan point (explain needs holds of
  // min_static_s + 2 static_trim_s = 6 s for its noise floor).
  double hold_s = 30.0;
  // Rate of the runs as a fraction of the bench's max rate, and of the second-rate runs: runs
  // below the limit keep the ramps (at max accel) short; a third of it is a clearly different
  // rate for rate-dependent terms.
  double run_rate_fraction = 1.0;
  double slow_rate_fraction = 1.0 / 3.0;
  // The noise-free simulation of a block (sample rates of the IMU and the encoders): the bins
  // are explain's (0.5 s) whatever the rates, 50 / 20 Hz resolve 30 deg/s runs and keep a
  // block's simulation and regressors fast.
  double imu_rate_hz = 50.0;
  double table_rate_hz = 20.0;

  bool IsValid(std::string* why) const;
};

// One group: an unseparable pair (two effects) or an accepted effect short of the precision.
struct ProposedGroup {
  std::vector<std::string> effects;
  bool unseparable = false;  // from ExplainResult::unseparable (else a precision request)
  // Principal angle between the effects' projected columns (unseparable pairs), rad: on the
  // recording and on the proposed plan; the limit is acos(unseparable_cos). One effect
  // unseparable from the baseline: the smallest angle of its parameters' columns to the
  // baseline's column space (limit asin(baseline_collinear)).
  double angle_before_rad = 0.0, angle_after_rad = 0.0;
  std::vector<std::string> flat_names;            // the effects' parameters
  std::vector<double> sigma_before, sigma_after;  // predicted, per flat name (NaN: not seen)
  // Predicted for the recording and the plan's recording analysed together (explain A B).
  std::vector<double> sigma_joint;
  std::vector<double> sigma_target;  // precision requests only (else empty)
  std::vector<std::string> added;    // purposes of the blocks that served it
  double added_duration_s = 0.0;
  bool resolved = false;
  // False: no plan of the candidate motions separates it (why says so), e.g. a base tilt about
  // the outer axis and the outer encoder zero, one rotation on a two-axis table.
  bool possible = true;
  std::string why;  // unresolved: what is missing
};

struct ProposeResult {
  Status status = Status::Error("not proposed");  // why not (bad options, expander refused)
  bool nothing_to_propose = false;                // no group: no plan
  // The plan (no blocks when no group can be served by any plan: every group impossible).
  ProposedPlan plan;
  double duration_s = 0.0;
  double angle_limit_rad = 0.0;           // pairs
  double baseline_angle_limit_rad = 0.0;  // one effect against the baseline
  std::vector<ProposedGroup> groups;
  std::vector<std::string> notes;

  // The principal-angle limit that judges `g`: a pair's, or one effect's against the baseline.
  double angleLimitFor(const ProposedGroup& g) const {
    return g.effects.size() > 1 ? angle_limit_rad : baseline_angle_limit_rad;
  }
};

// One group in JSON (the daemon's stored follow-up and `explain --propose-plan --json`):
// effects, unseparable / resolved / possible / why, the principal angles before and after and
// their limit (deg), the blocks added, and per parameter the predicted sigmas before (the
// recording), after (the plan alone) and joint (both analysed together); null = held.
nlohmann::json toJson(const ProposedGroup& group, const ProposeResult& proposal);

// The groups and the plan. `in` is the recording explain analysed, `res` its analysis (status
// ok), `eo` the options it ran with.
ProposeResult proposePlan(const ExplainInput& in, const ExplainResult& res,
                          const ExplainOptions& eo, const ProposeOptions& po,
                          const ProposalExpander& expand);

}  // namespace imubench::calib
