// Estimates against a known truth (simulated benches, certified reference units), parameter
// by parameter, with the accuracy targets of a navigation-grade calibration:
//   misalignments, base tilt, nonorthogonality within 3 arcsec; scale factors within 10 ppm;
//   biases within 2 sigma (a 95 % statement: about one bias in twenty lies outside by chance).
// The truth must first be put into the frame the method's coefficients refer to (for the
// navigation-based method toGyroReferenced(), calib/indirect/indirect_calibration.h): comparing raw
// misalignments with gyro-referenced ones would blame the calibration for the mounting.
// Pure: value types in, value types out.
#pragma once

#include <string>
#include <vector>

#include "calib/bench_truth.h"

namespace imubench::calib {

// How a coefficient is shown to people: SI value / si_per_unit in `label`. Scale factors in
// ppm, accelerometer biases in ug, gyro biases in deg/h, angles in arcsec.
struct DisplayUnit {
  double si_per_unit = 1.0;
  const char* label = "";
};
DisplayUnit displayUnit(const std::string& flat_name);

struct ComparisonRow {
  std::string name;       // flat name, e.g. "gyro.misalignment.xy"
  double estimate = 0.0;  // SI
  double expected = 0.0;  // SI, truth in the method's frame
  double error = 0.0;     // estimate - expected, SI
  double sigma = 0.0;     // reported sigma (0: none)
  std::string unit;       // display unit of `error`: "arcsec", "ppm", "ug", "deg/h"
  double error_in_unit = 0.0;
  double limit_in_unit = 0.0;  // the target in `unit` (biases: 2 sigma)
  bool within = true;          // |error| <= limit
  bool observable = true;      // false: held at the start value, not judged
  // false: an effect of the truth's "extra" section the estimate's model does not carry (its
  // value would be absorbed by the coefficients or left in the residual): shown, not judged.
  bool modelled = true;
};

struct TruthComparison {
  std::vector<ComparisonRow> rows;
  int judged = 0;      // rows with a target that were observable
  int outside = 0;     // of those, outside the target
  int unmodelled = 0;  // rows of truth effects the estimate does not model
};

// Compares every parameter the estimate carries an uncertainty entry for (sigma or an
// "observable": false flag): what the method estimated or deliberately held. Parameters without
// one (mounting and encoder zeros; the table under direct calibration) are not estimates.
// Extra effects (interchange.md "extra"): every real parameter of an effect in the truth or in
// the estimate; estimated ones (with a sigma) judged within 2 sigma (unit "SI"), the truth's
// effects the estimate does not model listed with modelled = false.
TruthComparison compareWithTruth(const CoefficientReport& estimate, const BenchTruth& expected);

}  // namespace imubench::calib
