// The production calibration of one device on one table, as a lab runs it:
//   1. direct calibration (0) from the direct plan's recording (calib/direct_calibration.h),
//      the table taken as nominal;
//   2. navigation-based refinement (calib/indirect/indirect_calibration.h) over the navigation
//   plan's
//      recordings AND the direct recording (same table, same mounting), started from (0):
//      sensor coefficients, base tilt and the table's axis nonorthogonality;
//   3. when the table's axes are found nonorthogonal: the direct calibration repeated with
//      that nonorthogonality (its gyro misalignments are measured against the table's rotation
//      axes and otherwise carry it), and the refinement again from it, until the
//      nonorthogonality settles (each pass removes about half of what is left). The gyro-referenced
//      convention keeps the direct gyro misalignments, so they must refer to the orthogonal
//      platform frame the refinement uses.
// Pure: value types in, value types out.
//
// Usage:
//   BenchCalibrationInput in;
//   in.direct = {geometry, site, imu, table, segments};          // direct plan recording (view)
//   in.navigation.push_back({nav_imu, nav_table, nav_segments});  // 12-run / three-axis plan
//   BenchCalibrationResult r = calibrateBench(in, BenchCalibrationOptions{});
//   if (!r.status.HasResult()) ... r.status.message;   r.refined.coefficients -> JSON
// Which method a recording gets, and from which start, is the calibration service's policy
// (calib/service/calibration_service.h); this file is its production pipeline.
#pragma once

#include <string>
#include <vector>

#include "calib/direct_calibration.h"
#include "calib/indirect/indirect_calibration.h"

namespace imubench::calib {

struct BenchCalibrationInput {
  RecordingView direct;                 // the direct plan's recording, site and geometry
  std::vector<IndirectLeg> navigation;  // navigation-plan recordings (views; may be empty)
};

struct BenchCalibrationOptions {
  DirectCalibrationOptions direct;
  IndirectOptions indirect;
  // Repeat direct + refinement with the estimated nonorthogonality when any component
  // exceeds this many of its sigmas (below it the correction is lost in the noise).
  double nonorthogonality_significance_sigma = 2.0;
  // Passes at most (1: no feedback). Each pass removes about half of the nonorthogonality the
  // direct gyro misalignments still carry (they are held by the gyro-referenced convention),
  // so a table with tens of arcsec needs several to come within an arcsec.
  int max_passes = 10;
  // Stop when no nonorthogonality component moved by more than this many of its sigmas.
  double convergence_sigma = 0.1;

  bool IsValid(std::string* why) const;
};

struct BenchCalibrationResult {
  // Whether the final coefficients can be used: the refinement's status, or kFailed with a
  // message naming which stage failed and why.
  FitStatus status = FitStatus::Failed("not calibrated");
  DirectCalibrationResult direct;        // (0): the first, table-unaware direct calibration
  DirectCalibrationResult direct_final;  // the direct calibration the refinement started from
  CalibrationResult refined;             // the final refinement
  int passes = 0;                        // 1, or more when the nonorthogonality was fed back
};

BenchCalibrationResult calibrateBench(const BenchCalibrationInput& input,
                                      const BenchCalibrationOptions& options = {});

// The same from a first direct calibration the caller already has (calibrateDirect of
// input.direct with options.direct): the calibration service's policy judges it before it
// chooses this pipeline, and it is not computed twice.
BenchCalibrationResult calibrateBenchFrom(const BenchCalibrationInput& input,
                                          const DirectCalibrationResult& first,
                                          const BenchCalibrationOptions& options = {});

}  // namespace imubench::calib
