// A table with its geometric errors, in double precision with the constant chain factors
// precomputed: a thin front of the one templated chain in calib/model/table_chain.h (which
// states the chains, frames and signs), plus the table's inverse (angles for an attitude).
//
// Small rotations: by default every (I + [t x]) factor is evaluated as the exact rotation
// exp([t x]) (ChainOptions::first_order_errors = false). The two agree to first order in t
// (difference O(|t|^2): 2e-8 rad for 30 arcsec), the exact form keeps C_LB orthonormal so the
// simulator's kinematics are exact. Set first_order_errors to evaluate the interchange chain
// literally (C_LB is then not orthonormal; kinematics still use the exact rotations).
//
// Angles: the motion's axis angles are the encoder readings (nominal angles, calib/model/motion.h);
// the physical rotation is reading + encoder zero. Axis order: two-axis [outer, inner],
// three-axis [outer, middle, inner]; `middle` is unused (0) for a two-axis table.
#pragma once

#include <array>
#include <string>

#include "calib/model/motion.h"
#include "calib/model/table_chain.h"
#include "nav/rotation.h"

namespace imubench::calib {

struct TableGeometry {
  TableKind kind = TableKind::kTwoAxis;
  // Two-axis only: heading of the outer axis, rad clockwise from North (interchange default
  // 90 deg = East). Ignored for a three-axis table (outer axis vertical).
  double outer_axis_heading_rad = kPi / 2.0;
};

// Axis perpendicularity errors, rad. Two-axis: nu = (0, inner_y, 0). Three-axis:
// nu1 = (middle_x, middle_y, 0), nu2 = (0, inner_y, 0). inner_y is the same physical error in
// both tables (the inner axis against the horizontal axis carrying it).
struct Nonorthogonality {
  double inner_y = 0.0;   // two-axis nu_y; three-axis nu2_y
  double middle_x = 0.0;  // three-axis nu1_x
  double middle_y = 0.0;  // three-axis nu1_y
};

// Encoder zero errors o0, m0, i0, rad (physical angle = reading + zero).
struct EncoderZero {
  double outer = 0.0;
  double middle = 0.0;  // three-axis only
  double inner = 0.0;
};

struct TableErrors {
  Vec2 base_tilt = Vec2::Zero();  // theta = (x, y, 0), rad, in L: base levelling error
  Nonorthogonality nonorthogonality;
  Vec2 mounting = Vec2::Zero();  // mu = (x, y, 0), rad: device installation on the platform
  EncoderZero encoder_zero;
};

// The errors as the model's parameter blocks (calib/model/table_chain.h offsets).
std::array<double, model::kTableAxesSize> axesBlock(const TableErrors& e);
std::array<double, model::kTableDeviceSize> deviceBlock(const TableErrors& e);
// The errors as the chain's factors see them.
model::ChainErrors<double> chainErrors(TableKind kind, const TableErrors& e);

// Angles of the table axes, rad (encoder readings).
struct TableAngles {
  double outer = 0.0;
  double middle = 0.0;  // three-axis only
  double inner = 0.0;
};

// Angle, rate and acceleration of every axis (encoder reading and its derivatives).
struct TableState {
  AxisState outer;
  AxisState middle;  // three-axis only
  AxisState inner;

  TableAngles angles() const { return {outer.angle, middle.angle, inner.angle}; }
};

// State of all axes of a Motion at time t (axis order of calib/model/motion.h mapped to names).
TableState tableStateAt(const Motion& motion, double t);
// The same from a per-axis array in motion.h order (2 or 3 entries).
TableAngles tableAnglesFromAxes(TableKind kind, const double* axis_angles);

// Attitude and body kinematics of the platform at one instant (C_LB, w_LB_B, wdot_LB_B).
using TableKinematics = model::ChainKinematics<double>;

struct ChainOptions {
  // false: small error rotations evaluated exactly (orthonormal C_LB); true: literally
  // I + [t x] as written in interchange.md (first order, C_LB not orthonormal).
  bool first_order_errors = false;
};

// Result of the inverse: table angles realising a desired attitude on the nominal table.
struct TableInverse {
  bool ok = false;            // false only when the geometry is invalid
  TableAngles angles;         // rad, in (-pi, pi]
  double residual_rad = 0.0;  // rotation angle between requested and realised C_LB
                              // (non-zero when a two-axis table cannot reach the attitude)
};

// A table: geometry + errors, with the constant chain factors precomputed.
class TableModel {
 public:
  TableModel() : TableModel(TableGeometry{}, TableErrors{}) {}
  TableModel(const TableGeometry& geometry, const TableErrors& errors,
             const ChainOptions& options = {});

  const TableGeometry& geometry() const { return geometry_; }
  const TableErrors& errors() const { return errors_; }

  // Attitude for encoder readings, with all table errors.
  Mat3 C_LB(const TableAngles& angles) const;
  // Attitude, w_LB_B and wdot_LB_B, analytically through the chain (sum over joints).
  TableKinematics kinematics(const TableState& state) const;

  // Nominal (error-free) attitude for the given angles: C_LB = H Rx(outer) Rz(inner) or
  // Rz(outer) Rx(middle) Rz(inner).
  Mat3 nominalC_LB(const TableAngles& angles) const;
  // Angles whose nominal attitude is closest to C_LB_desired (exact when reachable;
  // three-axis: any attitude; near the gimbal lock middle = 0 and outer = 0).
  TableInverse inverse(const Mat3& C_LB_desired) const;

 private:
  TableGeometry geometry_;
  TableErrors errors_;
  ChainOptions options_;
  model::ChainErrors<double> chain_errors_;
  model::ChainFactors<double> factors_;  // C_LB = A0 R_outer A1 [R_middle A2] R_inner A3
};

}  // namespace imubench::calib
