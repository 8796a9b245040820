// Repeated attitudes: is an unexplained residual a change with time or a term of the attitude?
//
// A static hold whose residual no library effect explains is compared with the other holds of
// the same attitude (the same gravity direction in the sensor frame, from the bins' mean
// accelerometer readings; no table model needed, so recordings without a table, the scalar
// analysis, qualify). When the same attitude held at another time reads differently by more
// than the window's significance, and by more than an attitude's small difference could make,
// the residual changes with time at one attitude: no static term can do that (a bias drift,
// effect id bias_instability, a warm-up or a step). When another visit of the attitude
// shows the same residual (and none differs), the residual repeats with the attitude: a term
// of the attitude, or a drift slower than the time between the visits. The finding is appended to
// the window's reason (interchange.md's "unexplained" rows have no other field for it); a
// window without a comparable visit keeps its reason.
#pragma once

#include <vector>

#include "calib/explain/explain.h"
#include "calib/explain/explain_model.h"
#include "calib/explain/explain_noise.h"

namespace imubench::calib {

struct RevisitOptions {
  // Largest angle between two visits' gravity directions for "the same attitude", rad. 2 deg:
  // hand-placed faces and repeated table positions agree far better; a smooth attitude term of
  // size A changes by ~A * 2 * angle, under a tenth of A here.
  double same_attitude_rad = 0.0349;
  // Shortest visit compared, s (its mean must average the noise like the window's).
  double min_visit_s = 2.0;
  // A change with time must also be at least this fraction of the larger of the two residuals:
  // a smaller one could come from the two visits' slightly different attitudes.
  double min_change_fraction = 0.5;
  // Largest difference, in sigmas of the difference, for "the same residual" at another visit.
  double same_sigma = 3.0;
};

// Appends to each window of `windows` (any channel) what its attitude's other visits say,
// judged on the window's part in the static visit it overlaps most (a window with less than
// RevisitOptions::min_visit_s of one is left as it is). r and model_sigma: per bin and
// channel (bin * 6 + channel), as ExplainProblem holds them; significance: the windows'
// threshold in sigmas (ExplainOptions::unexplained_sigma).
void nameRevisits(const std::vector<ExplainBin>& bins, const std::vector<double>& r,
                  const std::vector<double>& model_sigma, const NoiseFloor& nf, double significance,
                  const RevisitOptions& o, std::vector<ExplainWindow>* windows);

}  // namespace imubench::calib
