#include "io/thermal_report.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "io/html_report.h"

namespace imubench::io {
namespace {

namespace model = calib::model;

std::string esc(const std::string& s) {
  return htmlEscape(s);
}
std::string num(double v, const char* fmt = "%.4g") {
  return htmlNumber(v, fmt);
}

// How one block entry is shown: y = (value - offset) * factor in `unit`.
struct DisplayUnit {
  double offset = 0.0;
  double factor = 1.0;
  const char* unit = "";
};

DisplayUnit displayUnit(bool accel, int i) {
  constexpr double kPi = 3.14159265358979323846;
  if (i < model::kBias) return {1.0, 1e6, "ppm (scale &minus; 1)"};
  if (i < model::kMis) {
    return accel ? DisplayUnit{0.0, 1.0 / 9.80665e-6, "&micro;g"}
                 : DisplayUnit{0.0, 180.0 / kPi * 3600.0, "deg/h"};
  }
  return {0.0, 1e6, "&micro;rad"};
}

// 1-sigma of the polynomial at dT from the per-term sigmas, taken as independent: the file
// keeps no covariance between the terms, so their correlation is left out (with t_ref inside
// the range the terms' correlation is moderate; the band is indicative, not exact).
double polySigma(const model::ThermalCoefficient& c, double dT) {
  double var = 0.0, p = 1.0;
  for (int k = 0; k <= c.order; ++k, p *= dT) {
    var += std::pow(c.sigma_poly[static_cast<std::size_t>(k)] * p, 2);
  }
  return std::sqrt(var);
}

// The plot's frame: data coordinates to SVG pixels.
struct Frame {
  double W = 520, H = 240, left = 70, right = 10, top = 10, bottom = 30;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * (W - left - right); }
  double Y(double y) const { return H - bottom - (y - y0) / (y1 - y0) * (H - top - bottom); }
};

// Median |rate| of the points taken heating or cooling (0 when none).
double typicalRate(const std::vector<calib::ThermalFitPoint>& points, double min_rate) {
  std::vector<double> r;
  for (const auto& p : points) {
    if (std::abs(p.temp_rate) > min_rate) r.push_back(std::abs(p.temp_rate));
  }
  if (r.empty()) return 0.0;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return r[r.size() / 2];
}

void header(const calib::ThermalRunsFitResult& fit, const ThermalReportOptions& opt, double rate,
            std::ostringstream& o) {
  const model::ThermalCoefficients& c = fit.fit.coefficients;
  o << "<h2>Calibrated range</h2><p class=bad><b>Calibrated range: " << num(c.t_min_c, "%.2f")
    << " .. " << num(c.t_max_c, "%.2f")
    << " degC.</b> Outside it the model extrapolates: every coefficient is held at its value at "
       "the nearest edge (interchange.md), and <code>imubench apply</code> flags every sample "
       "there. The plots shade the extrapolated region.</p>\n<p>Method: <b>"
    << esc(opt.method) << "</b>; polynomial origin t_ref " << num(c.t_ref_c, "%.2f") << " degC; "
    << fit.fit.distinct_temperatures << " distinct temperatures"
    << (fit.fit.hysteresis_candidate ? ", taken heating and cooling" : "") << "; "
    << fit.points.size() << " per-point estimates"
    << (fit.points.empty() ? " (the joint fit uses the raw rows: no points to plot)" : "") << ". "
    << (rate > 0 ? "Heating/cooling branches drawn at &plusmn;" + num(rate * 60.0, "%.3g") +
                       " degC/min (the data's typical rate)."
                 : std::string("No heating or cooling in the data: no branches drawn."))
    << "</p>\n";
}

void coefficientTable(const calib::ThermalRunsFitResult& fit, std::ostringstream& o) {
  o << "<h2>Coefficients</h2><table><tr><th class=l>coefficient</th><th>order</th>"
       "<th>dT/dt term</th><th>c0 at t_ref</th><th>&sigma; c0</th><th>dT/dt, per degC/min</th>"
       "<th class=l>unit</th><th>points</th><th>&chi;<sup>2</sup>/n</th></tr>\n";
  std::size_t n = 0;
  for (const bool accel : {true, false}) {
    const model::ThermalTriad& t = accel ? fit.fit.coefficients.accel : fit.fit.coefficients.gyro;
    for (int i = 0; i < model::kTriadSize; ++i, ++n) {
      const model::ThermalCoefficient& c = t[static_cast<std::size_t>(i)];
      const DisplayUnit u = displayUnit(accel, i);
      const calib::ThermalCoefficientFit* f = n < fit.fit.fits.size() ? &fit.fit.fits[n] : nullptr;
      o << "<tr><td class=l>"
        << esc(f ? f->name : calib::thermalCoefficientName(accel ? "accel" : "gyro", i))
        << "</td><td>" << c.order << "</td><td>" << (c.hysteresis ? "yes" : "no") << "</td><td>"
        << num((c.poly[0] - u.offset) * u.factor, "%+.5g") << "</td><td>"
        << num(c.sigma_poly[0] * u.factor, "%.3g") << "</td><td>"
        << (c.hysteresis ? num(c.dTdt * u.factor / 60.0, "%+.4g") + " &plusmn; " +
                               num(c.sigma_dTdt * u.factor / 60.0, "%.2g")
                         : std::string("&ndash;"))
        << "</td><td class=l>" << u.unit << "</td><td>" << (f ? f->points : 0) << "</td><td>"
        << num(f && f->points > 0 ? f->chi2 / f->points : NAN, "%.3g") << "</td></tr>\n";
    }
  }
  o << "</table>\n";
}

// The curve of one coefficient at temp_rate over the frame's x range, in display units.
std::vector<std::pair<double, double>> curve(const model::ThermalCoefficients& cs,
                                             const model::ThermalCoefficient& c,
                                             const DisplayUnit& u, const Frame& f, double temp_rate,
                                             double sigma_sign) {
  std::vector<std::pair<double, double>> xy;
  constexpr int kSamples = 120;
  for (int s = 0; s <= kSamples; ++s) {
    const double T = f.x0 + (f.x1 - f.x0) * s / kSamples;
    const double dT = model::thermalPoint(cs, T).temp_c - cs.t_ref_c;
    const double v = model::thermalValue(c, dT, temp_rate) + sigma_sign * polySigma(c, dT);
    xy.emplace_back(T, (v - u.offset) * u.factor);
  }
  return xy;
}

std::string svgPoints(const std::vector<std::pair<double, double>>& xy, const Frame& f) {
  std::string s;
  for (const auto& [x, y] : xy) s += num(f.X(x), "%.1f") + "," + num(f.Y(y), "%.1f") + " ";
  return s;
}

// The frame of one coefficient's plot: x the calibrated range and the points plus a margin on
// each side (where the model is held), y everything drawn.
Frame plotFrame(const calib::ThermalRunsFitResult& fit, const model::ThermalCoefficient& c,
                const DisplayUnit& u, bool accel, int i, double rate) {
  const model::ThermalCoefficients& cs = fit.fit.coefficients;
  Frame f;
  f.x0 = cs.t_min_c;
  f.x1 = cs.t_max_c;
  for (const auto& p : fit.points) {
    f.x0 = std::min(f.x0, p.temp_c);
    f.x1 = std::max(f.x1, p.temp_c);
  }
  const double margin = std::max(0.1 * (f.x1 - f.x0), 2.0);
  f.x0 -= margin;
  f.x1 += margin;
  double lo = INFINITY, hi = -INFINITY;
  const auto take = [&](double y) {
    if (std::isfinite(y)) lo = std::min(lo, y), hi = std::max(hi, y);
  };
  for (const double sign : {-1.0, 1.0}) {
    for (const auto& [x, y] : curve(cs, c, u, f, 0.0, sign)) take(y);
    if (c.hysteresis && rate > 0) {
      for (const auto& [x, y] : curve(cs, c, u, f, sign * rate, 0.0)) take(y);
    }
  }
  const std::size_t k = static_cast<std::size_t>(i);
  for (const auto& p : fit.points) {
    if (!(accel ? p.observable_accel : p.observable_gyro)[k]) continue;
    const double y = ((accel ? p.accel : p.gyro)[k] - u.offset) * u.factor;
    const double s = (accel ? p.sigma_accel : p.sigma_gyro)[k] * u.factor;
    take(y - s);
    take(y + s);
  }
  if (!(hi > lo)) lo -= 1.0, hi += 1.0;
  const double pad = 0.08 * (hi - lo) + 1e-12 * std::max(std::abs(hi), std::abs(lo));
  f.y0 = lo - pad;
  f.y1 = hi + pad;
  return f;
}

// One marker: heating a red triangle up, cooling a blue triangle down, soaked a black circle;
// with its 1-sigma bar.
void marker(const Frame& f, double x, double y, double s, double rate, double min_rate,
            std::ostringstream& o) {
  const double px = f.X(x), py = f.Y(y);
  const char* colour = rate > min_rate ? "#c0392b" : rate < -min_rate ? "#1f5fbf" : "#222";
  o << "<line x1=" << num(px, "%.1f") << " x2=" << num(px, "%.1f")
    << " y1=" << num(f.Y(y - s), "%.1f") << " y2=" << num(f.Y(y + s), "%.1f") << " stroke='"
    << colour << "'/>";
  if (rate > min_rate || rate < -min_rate) {
    const double d = rate > 0 ? -5 : 5;  // apex up when heating
    o << "<polygon fill='" << colour << "' points='" << num(px, "%.1f") << ","
      << num(py + d, "%.1f") << " " << num(px - 4.5, "%.1f") << "," << num(py - d * 0.6, "%.1f")
      << " " << num(px + 4.5, "%.1f") << "," << num(py - d * 0.6, "%.1f") << "'/>\n";
  } else {
    o << "<circle cx=" << num(px, "%.1f") << " cy=" << num(py, "%.1f") << " r=3.5 fill='" << colour
      << "'/>\n";
  }
}

// Axes: the y extremes and x ticks every nice step, the calibrated range's edges as lines with
// the extrapolated regions shaded.
void axes(const Frame& f, const model::ThermalCoefficients& cs, const DisplayUnit& u,
          std::ostringstream& o) {
  const double plot_bottom = f.H - f.bottom;
  o << "<rect x=" << num(f.left, "%.1f") << " y=" << f.top
    << " width=" << num(f.X(cs.t_min_c) - f.left, "%.1f") << " height=" << plot_bottom - f.top
    << " fill='#e4e4e4'/><rect x=" << num(f.X(cs.t_max_c), "%.1f") << " y=" << f.top
    << " width=" << num(f.W - f.right - f.X(cs.t_max_c), "%.1f")
    << " height=" << plot_bottom - f.top << " fill='#e4e4e4'/>\n";
  for (const double t : {cs.t_min_c, cs.t_max_c}) {
    o << "<line x1=" << num(f.X(t), "%.1f") << " x2=" << num(f.X(t), "%.1f") << " y1=" << f.top
      << " y2=" << plot_bottom << " stroke='#555' stroke-dasharray='4,3'/>\n";
  }
  o << "<text x=" << num(f.X(cs.t_min_c) - 4, "%.1f") << " y=" << f.top + 12
    << " font-size=10 text-anchor=end>extrapolated (held)</text><text x="
    << num(f.X(cs.t_max_c) + 4, "%.1f") << " y=" << f.top + 12
    << " font-size=10>extrapolated (held)</text>\n";
  const double span = f.x1 - f.x0;
  const double step = span > 100 ? 20 : span > 40 ? 10 : span > 15 ? 5 : 1;
  for (double t = std::ceil(f.x0 / step) * step; t <= f.x1; t += step) {
    o << "<text x=" << num(f.X(t), "%.1f") << " y=" << f.H - 16
      << " font-size=10 text-anchor=middle>" << num(std::abs(t) < 1e-9 ? 0.0 : t, "%.0f")
      << "</text>";
  }
  o << "<text x=" << num(f.W / 2, "%.0f") << " y=" << f.H - 3
    << " font-size=11 text-anchor=middle>IMU temperature, degC</text>\n"
    << "<text x=" << f.left - 4 << " y=" << f.top + 10 << " font-size=10 text-anchor=end>"
    << num(f.y1, "%.4g") << "</text><text x=" << f.left - 4 << " y=" << plot_bottom
    << " font-size=10 text-anchor=end>" << num(f.y0, "%.4g")
    << "</text><text x=4 y=" << num(f.H / 2, "%.0f") << " font-size=10>" << u.unit << "</text>\n";
}

void coefficientPlot(const calib::ThermalRunsFitResult& fit, bool accel, int i, double rate,
                     double min_rate, std::ostringstream& o) {
  const model::ThermalCoefficients& cs = fit.fit.coefficients;
  const model::ThermalCoefficient& c = (accel ? cs.accel : cs.gyro)[static_cast<std::size_t>(i)];
  const DisplayUnit u = displayUnit(accel, i);
  const Frame f = plotFrame(fit, c, u, accel, i, rate);
  o << "<h3>" << calib::thermalCoefficientName(accel ? "accel" : "gyro", i) << " (order " << c.order
    << (c.hysteresis ? ", dT/dt term" : "") << ")</h3>\n<svg width=" << f.W << " height=" << f.H
    << " viewBox='0 0 " << f.W << " " << f.H << "'>\n";
  axes(f, cs, u, o);
  std::vector<std::pair<double, double>> band = curve(cs, c, u, f, 0.0, 1.0);
  const auto lower = curve(cs, c, u, f, 0.0, -1.0);
  band.insert(band.end(), lower.rbegin(), lower.rend());
  o << "<polygon fill='#bcd3f0' stroke=none points='" << svgPoints(band, f) << "'/>\n";
  if (c.hysteresis && rate > 0) {
    for (const double sign : {1.0, -1.0}) {
      o << "<polyline fill=none stroke='" << (sign > 0 ? "#c0392b" : "#1f5fbf")
        << "' stroke-dasharray='6,3' points='" << svgPoints(curve(cs, c, u, f, sign * rate, 0.0), f)
        << "'/>\n";
    }
  }
  o << "<polyline fill=none stroke='#0b3d91' stroke-width=2 points='"
    << svgPoints(curve(cs, c, u, f, 0.0, 0.0), f) << "'/>\n";
  const std::size_t k = static_cast<std::size_t>(i);
  for (const auto& p : fit.points) {
    if (!(accel ? p.observable_accel : p.observable_gyro)[k]) continue;
    marker(f, p.temp_c, ((accel ? p.accel : p.gyro)[k] - u.offset) * u.factor,
           (accel ? p.sigma_accel : p.sigma_gyro)[k] * u.factor, p.temp_rate, min_rate, o);
  }
  o << "</svg>\n";
}

}  // namespace

std::string thermalReportHtml(const calib::ThermalRunsFitResult& fit,
                              const ThermalReportOptions& opt) {
  const double rate =
      opt.typical_rate > 0 ? opt.typical_rate : typicalRate(fit.points, opt.min_rate);
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>imubench thermal fit: "
    << esc(opt.title) << "</title><style>" << kHtmlReportStyle << "</style></head><body>\n"
    << "<h1>imubench thermal fit: " << esc(opt.title) << "</h1>\n";
  header(fit, opt, rate, o);
  coefficientTable(fit, o);
  o << "<h2>Coefficients against temperature</h2><p class=legend><span style='color:#0b3d91'>"
       "line: the fit at dT/dt = 0</span><span style='background:#bcd3f0'>its 1&sigma; band"
       "</span><span style='color:#c0392b'>&#9650; heating point, dashed: heating branch</span>"
       "<span style='color:#1f5fbf'>&#9660; cooling point, dashed: cooling branch</span>"
       "<span>&#9679; soaked point</span><span style='background:#e4e4e4'>outside the "
       "calibrated range: extrapolated (held at the edge)</span></p>\n";
  for (const bool accel : {true, false}) {
    for (int i = 0; i < model::kTriadSize; ++i)
      coefficientPlot(fit, accel, i, rate, opt.min_rate, o);
  }
  o << "</body></html>\n";
  return o.str();
}

Status writeThermalReport(const std::string& dir, const calib::ThermalRunsFitResult& fit,
                          const ThermalReportOptions& options) {
  return writeHtmlReport(dir, thermalReportHtml(fit, options));
}

}  // namespace imubench::io
