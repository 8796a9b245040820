// Are the scalar calibration's sigmas honest on this recording? Two checks that need no
// truth (issue 18, "sigmas are honest on real data"):
//   - the normalised residual RMS of the accelerometer fit: sqrt(chi^2 / dof) of each static
//     pose's |f| - g against the pose mean's white-noise sigma (per-sample scatter / sqrt(n));
//     1 when the model explains the poses down to their noise, above 1 when something is left
//     (or the noise is not white: a mean over a long pose is then less certain than sqrt(n)
//     says);
//   - a second estimate: the recording is cut in two at the static pose nearest its middle,
//     each half is calibrated on its own, and every coefficient observable in both halves is
//     compared, z = (a - b) / sqrt(sigma_a^2 + sigma_b^2). Honest sigmas give z of order 1
//     (RMS z near 1, |z| beyond 3 rare); RMS z >> 1 means the sigmas are too small.
// Pure: values in, values out.
#pragma once

#include <string>
#include <vector>

#include "calib/calibration_result.h"
#include "calib/scalar/scalar_calibration.h"

namespace imubench::calib {

struct ScalarConsistencyRow {
  std::string name;  // flat name, e.g. "accel.scale.x"
  double first = 0.0, first_sigma = 0.0;
  double second = 0.0, second_sigma = 0.0;
  double z = 0.0;
};

struct ScalarConsistency {
  // The static poses' accelerometer readings show no noise (noise-free or quantisation-
  // limited data: at most kMaxResolutionValues distinct values per pose on some axis, median
  // over poses): there is no white-noise sigma to normalise by, so accel_normalised_rms is
  // NaN and the halves are not compared (their sigmas are not meaningful either).
  bool resolution_limited = false;
  // Normalised residual RMS of the accelerometer fit over the full recording's poses.
  double accel_normalised_rms = 0.0;
  int accel_dof = 0;
  // Half against half: ok = false (why) when a half cannot be calibrated on its own.
  bool halves_ok = false;
  std::string halves_why;
  double split_t = 0.0;  // s: time of the cut (middle of a static pose)
  std::size_t first_poses = 0, second_poses = 0;
  std::vector<ScalarConsistencyRow> rows;
  double rms_z = 0.0;
  double max_abs_z = 0.0;
  std::string worst;  // name with the largest |z|
};

// `full` is scalarCalibrate(data, options, accel_unit_is_si) (status ok). The halves are
// calibrated with the same options, except that the second half's first pose (half of the
// pose the cut goes through) serves as its initial static whatever its length.
ScalarConsistency scalarConsistency(const RawImuData& data, const ScalarCalibrationResult& full,
                                    const ScalarCalibrationOptions& options, bool accel_unit_is_si);

// The half-against-half comparison as the sigma check of the full calibration's sigmas
// (calib/calibration_result.h): each compared coefficient's |z| / 0.674 (the median of |z| for
// honest sigmas is 0.674) is its ratio of resampled to printed sigma, so the median ratio is
// ~1 when the sigmas are honest. Not done (why_not) when the halves were not compared.
SigmaCheck sigmaCheckFromHalves(const ScalarConsistency& c, const CoefficientReport& full,
                                const SigmaCheckOptions& options);

// Plain text, one line per item, each ending in '\n'.
std::string describe(const ScalarConsistency& c);

}  // namespace imubench::calib
