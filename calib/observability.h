// Observability of a calibration's parameter set: Fisher information J^T W J of the
// linearised measurement model, its eigen-decomposition, the weakly/unobservable directions
// expressed in NAMED parameters, and plain-language statements.
//
// Two layers:
//  - analyseInformation(): pure linear algebra on any Jacobian with named columns (used by
//    the scalar and direct calibrators to say which parameters a badly conditioned solve
//    blames);
//  - analysePlanObservability(): for a table Motion (a plan expanded by plans/) and a method,
//    builds the Jacobian of the method's measurement model around the nominal (all errors
//    zero) by automatic differentiation (ceres::Jet) of the forward model in calib/model/ (the
//    functions the calibrators' costs evaluate) and analyses it.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/motion.h"
#include "nav/earth.h"

namespace imubench::calib {

struct InformationOptions {
  // An eigenvalue below rel_tol * largest is a null direction: double-precision numeric
  // Jacobians resolve ~1e-10 relative; real weakly-observable directions sit far above.
  double rel_tol = 1e-9;
  // Components smaller than this (unit eigenvector) are left out of the description.
  double show_component = 0.05;

  bool IsValid(std::string* why) const;
};

struct NullDirection {
  double eigenvalue = 0.0;  // of the (column-normalised) information matrix
  Eigen::VectorXd vector;   // unit, over all parameters
  std::string description;  // "mounting.x + accel.misalignment.zy (0.71, -0.71)"
};

struct InformationAnalysis {
  Status status;  // why not (bad options, a Jacobian that does not match the names)
  std::vector<std::string> names;
  Eigen::MatrixXd fisher;        // J^T J (columns scaled to unit norm, see column_scale)
  Eigen::VectorXd column_scale;  // norm of each Jacobian column (0: parameter never seen)
  Eigen::VectorXd eigenvalues;   // ascending
  Eigen::MatrixXd eigenvectors;  // columns, matching eigenvalues
  std::vector<NullDirection> null_directions;
  // Per parameter: true when it has no component in any null direction above show_component.
  std::vector<bool> observable;
  double condition = 0.0;  // largest / smallest eigenvalue above the null threshold
};

// Analyses the information of a Jacobian (rows = measurements, already whitened; columns =
// parameters named by names). Columns are normalised first so unit choices do not matter.
InformationAnalysis analyseInformation(const Eigen::MatrixXd& jacobian,
                                       const std::vector<std::string>& names,
                                       const InformationOptions& options = {});

// "a + b (0.71, -0.71)" for a unit direction over names.
std::string describeDirection(const Eigen::VectorXd& v, const std::vector<std::string>& names,
                              double show_component);

// ---- Plan observability ----

enum class CalibrationMethod { kDirect, kIndirect };

struct PlanObservabilityOptions {
  nav::Site site;  // latitude and gravity of the bench
  // Two-axis outer-axis heading, rad clockwise from North (interchange.md default: East).
  double outer_axis_heading_rad = 0.5 * 3.14159265358979323846;
  // Measurement noise (1 sigma) used to whiten rows: accel m/s^2 per static mean, gyro rad
  // per integrated rotation; only ratios matter for null spaces.
  double accel_sigma = 1e-4;
  double angle_sigma = 1e-5;
  InformationOptions information;

  bool IsValid(std::string* why) const;
};

struct PlanObservability {
  // Every physical parameter (sensor coefficients, all table errors, gravity and latitude
  // errors): what the data can tell apart at all.
  InformationAnalysis analysis;
  // The method's own parameter set, after its conventions: the direct method takes the table
  // as nominal (sensor coefficients only); the navigation-based method absorbs the mounting
  // and the inner encoder zero into the misalignments, the two-axis outer zero into the base
  // tilt and the three-axis middle zero into nonorthogonality middle_x (sensor coefficients,
  // base tilt, nonorthogonality). This is what the calibrator solves for; its unobservable
  // parameters are the ones the calibrator fixes and flags.
  InformationAnalysis model_analysis;
  std::vector<std::string> statements;  // plain language
};

// Parameter names of the set studied (sensor coefficients + table errors of this kind).
std::vector<std::string> observabilityParameterNames(TableKind kind);

PlanObservability analysePlanObservability(const Motion& motion, CalibrationMethod method,
                                           const PlanObservabilityOptions& options = {});

}  // namespace imubench::calib
