// The model-discrepancy analysis (calib/explain/explain.h) on a recording WITHOUT table angles
// (imu_tk, imucal and other hand-posed sessions): the static poses are the recording's bins.
//
// Model of a bin inside static pose p: the specific force is gravity along an unknown
// direction u_p (two nuisance angles per pose, about the direction the scalar calibration
// found), the rate is zero; the readings are the library's sensor equation with its effects
// (calib/effects.h forwardReadings) in the recording's reading units. The gyro at rest sees
// the Earth rate: its vertical component lies along gravity, i.e. along u_p, and is fitted (one
// nuisance parameter: an unknown latitude is allowed; otherwise it would pass for an isotropic
// g-sensitivity); its horizontal part depends on the pose's unknown heading and is carried as
// a model uncertainty of the gyro rows (it does not average down). Gravity is the options' value,
// shifted by gravity_error when that candidate is tested.
// Baseline: calib/scalar/scalar_calibration.h's coefficients of both triads (accelerometer scale,
// bias, the three misalignments |f| = g can see; gyro bias), refitted jointly with the poses.
// What such a recording can show: effects of the static readings (accel_k2, gyro
// g-sensitivity, thermal terms when the temperature moves); everything that needs table
// motion (lever arm, delays, asymmetry) is reported as not excited.
#pragma once

#include "calib/explain/explain.h"
#include "calib/scalar/scalar_calibration.h"

namespace imubench::calib {

// accel_unit_is_si as for scalarCalibrate. The result's baseline_method is "scalar"; its
// segments are the static poses.
ExplainResult explainScalar(const RawImuData& data, const ScalarCalibrationOptions& scalar,
                            bool accel_unit_is_si, const ExplainOptions& options = {});

}  // namespace imubench::calib
