// The thermal fit's report for people: DIR/report.html, one self-contained file (inline SVG and
// CSS, no script, no network; io/html_report.h) with
//   - the calibrated range [t_min, t_max] and the flag that outside it the model extrapolates
//     (held at the edge value, interchange.md "Thermal compensation file");
//   - per coefficient the selected order, the dT/dt term, c0 and the fit's diagnostics;
//   - one plot per coefficient of both triads (scale, bias, misalignment: 24): against the IMU
//     temperature, the per-point estimates with their 1-sigma bars (heating, cooling and soaked
//     points in their own colour and shape; the joint method has none), the fitted polynomial
//     at dT/dt = 0 with its 1-sigma band, the heating and cooling branches at the data's typical
//     +-dT/dt when the coefficient has a dT/dt term, and the calibrated range marked.
// Units as people read them: scale as ppm of (scale - 1), accel bias in ug, gyro bias in deg/h,
// misalignments in urad.
#pragma once

#include <string>

#include "base/status.h"
#include "calib/thermal/thermal_fit.h"

namespace imubench::io {

struct ThermalReportOptions {
  // What was fitted (the recordings or run ids), for the title.
  std::string title;
  // The fit's method ("joint" or "points"), stated in the header.
  std::string method;
  // Typical |dT/dt| of the data, degC/s: where the heating and cooling branches are drawn. 0:
  // the median |rate| of the points taken heating or cooling; no branches when that is 0 too.
  double typical_rate = 0.0;
  // Points with |rate| below this count as soaked (neither heating nor cooling): the fit's own
  // threshold for a dT/dt term, so the shapes show the split the fit used.
  double min_rate = calib::ThermalFitOptions{}.min_hysteresis_rate;
};

// The HTML text of the report of a successful fit (fit.status.HasResult()).
std::string thermalReportHtml(const calib::ThermalRunsFitResult& fit,
                              const ThermalReportOptions& options);

// Creates DIR when needed and writes DIR/report.html (temp file + rename).
Status writeThermalReport(const std::string& dir, const calib::ThermalRunsFitResult& fit,
                          const ThermalReportOptions& options);

}  // namespace imubench::io
