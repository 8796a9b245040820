#include "io/explain_report.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "io/html_report.h"

namespace imubench::io {
namespace {

std::string esc(const std::string& s) {
  return htmlEscape(s);
}
std::string num(double v, const char* fmt = "%.4g") {
  return htmlNumber(v, fmt);
}

void verdict(const calib::ExplainResult& r, std::ostringstream& o) {
  o << "<h2>Verdict</h2><p>Baseline: <b>" << esc(r.baseline_method)
    << "</b>. Normalised residual RMS (1 = the noise floor): <b>"
    << num(r.baseline_normalised_rms, "%.3f") << "</b> before, <b>"
    << num(r.after_normalised_rms, "%.3f") << "</b> after the refit with " << r.accepted.size()
    << " accepted effect(s). "
    << (r.unexplained.empty()
            ? "<span class=ok>No window is left beyond the noise floor.</span>"
            : "<span class=bad>" + std::to_string(r.unexplained.size()) +
                  " window(s) stay beyond the noise floor: nothing in the library explains "
                  "them.</span>")
    << "</p>\n<table><tr><th class=l>channel</th><th>RMS before</th><th>RMS after</th>"
       "<th>noise alone</th><th>before/noise</th><th>after/noise</th></tr>\n";
  for (int c = 0; c < 6; ++c) {
    const double n = r.noise_rms[static_cast<std::size_t>(c)];
    const double b = r.rms_before[static_cast<std::size_t>(c)];
    const double a = r.rms_after[static_cast<std::size_t>(c)];
    o << "<tr><td class=l>" << calib::explainChannelName(c) << "</td><td>" << num(b) << "</td><td>"
      << num(a) << "</td><td>" << num(n) << "</td><td>" << num(n > 0 ? b / n : NAN, "%.2f")
      << "</td><td>" << num(n > 0 ? a / n : NAN, "%.2f") << "</td></tr>\n";
  }
  o << "</table><p>Units: readings' rates (m/s<sup>2</sup>, rad/s, or the source's units for "
       "a third-party recording), over the analysis bins.</p>\n";
}

void effects(const calib::ExplainResult& r, std::ostringstream& o) {
  o << "<h2>Accepted effects</h2>\n";
  if (r.accepted.empty()) o << "<p>None: nothing in the library is warranted.</p>\n";
  for (const calib::ExplainAccepted& a : r.accepted) {
    o << "<h3>" << esc(a.effect) << "</h3><p>&Delta;BIC " << num(a.delta_bic, "%.1f")
      << ", likelihood-ratio statistic " << num(a.lr_stat, "%.1f")
      << ", p = " << num(a.p_value, "%.3g") << "</p><table><tr><th class=l>parameter (SI)</th>"
      << "<th>value</th><th>sigma</th></tr>\n";
    for (std::size_t k = 0; k < a.values.size(); ++k) {
      o << "<tr><td class=l>" << esc(a.flat_names[k]) << "</td><td>" << num(a.values[k], "%+.6g")
        << "</td><td>" << num(a.sigmas[k], "%.3g") << "</td></tr>\n";
    }
    o << "</table>\n";
  }
  o << "<h2>Rejected alternatives</h2><table><tr><th class=l>effect</th><th>&Delta;BIC</th>"
       "<th class=l>why</th></tr>\n";
  for (const calib::ExplainRejected& x : r.rejected) {
    o << "<tr><td class=l>" << esc(x.effect) << "</td><td>" << num(x.delta_bic, "%.1f")
      << "</td><td class=l>" << esc(x.reason) << "</td></tr>\n";
  }
  o << "</table>\n<h2>Unseparable on this recording</h2>\n<ul>\n";
  for (const calib::ExplainUnseparable& u : r.unseparable)
    o << "<li>" << esc(u.reason) << "</li>\n";
  if (r.unseparable.empty()) o << "<li>none</li>\n";
  o << "</ul>\n";
}

// One channel's residual in sigmas against time: before (grey) and after (blue) as polylines,
// located windows orange and unexplained ones red behind them.
void channelPlot(const calib::ExplainResult& r, int c, std::ostringstream& o) {
  if (r.bins.empty()) return;
  const double W = 1000, H = 160, t0 = r.bins.front().t0, t1 = r.bins.back().t1;
  double ymax = 5.0;
  for (const calib::ExplainBinResidual& b : r.bins) {
    const double s = b.sigma[static_cast<std::size_t>(c)];
    if (s > 0) ymax = std::max(ymax, std::abs(b.before[static_cast<std::size_t>(c)]) / s);
  }
  ymax = std::min(ymax, 200.0);
  const auto X = [&](double t) { return (t - t0) / std::max(t1 - t0, 1e-9) * W; };
  const auto Y = [&](double v) { return H / 2 - std::clamp(v / ymax, -1.0, 1.0) * (H / 2 - 4); };
  o << "<h3>" << calib::explainChannelName(c) << "</h3><svg width=" << W << " height=" << H
    << " viewBox='0 0 " << W << " " << H << "'>\n";
  for (const auto* ws : {&r.located, &r.unexplained}) {
    const char* fill = ws == &r.located ? "#ffd9a0" : "#ff9c9c";
    for (const calib::ExplainWindow& w : *ws) {
      if (w.channel != c) continue;
      o << "<rect x=" << num(X(w.t0), "%.1f")
        << " y=0 width=" << num(std::max(1.0, X(w.t1) - X(w.t0)), "%.1f") << " height=" << H
        << " fill='" << fill << "'/>\n";
    }
  }
  o << "<line x1=0 x2=" << W << " y1=" << H / 2 << " y2=" << H / 2 << " stroke='#999'/>\n";
  for (int pass = 0; pass < 2; ++pass) {
    o << "<polyline fill=none stroke='" << (pass == 0 ? "#999" : "#1f5fbf")
      << "' stroke-width=1 points='";
    for (const calib::ExplainBinResidual& b : r.bins) {
      const double s = b.sigma[static_cast<std::size_t>(c)];
      const double v = (pass == 0 ? b.before : b.after)[static_cast<std::size_t>(c)];
      o << num(X(0.5 * (b.t0 + b.t1)), "%.1f") << ',' << num(Y(s > 0 ? v / s : 0), "%.1f") << ' ';
    }
    o << "'/>\n";
  }
  o << "<text x=4 y=12 font-size=11>+" << num(ymax, "%.0f")
    << " &sigma;</text><text x=4 y=" << H - 4 << " font-size=11>&minus;" << num(ymax, "%.0f")
    << " &sigma;  (t " << num(t0, "%.0f") << "&ndash;" << num(t1, "%.0f") << " s)</text></svg>\n";
}

// Residual RMS in sigmas per segment and channel, before / after.
void segmentTable(const calib::ExplainResult& r, std::ostringstream& o) {
  const std::size_t n = r.segments.size();
  std::vector<std::array<double, 12>> sum(n, std::array<double, 12>{});
  std::vector<int> count(n, 0);
  for (const calib::ExplainBinResidual& b : r.bins) {
    if (b.segment < 0 || static_cast<std::size_t>(b.segment) >= n) continue;
    const std::size_t s = static_cast<std::size_t>(b.segment);
    ++count[s];
    for (std::size_t c = 0; c < 6; ++c) {
      if (b.sigma[c] <= 0) continue;
      sum[s][c] += std::pow(b.before[c] / b.sigma[c], 2);
      sum[s][6 + c] += std::pow(b.after[c] / b.sigma[c], 2);
    }
  }
  o << "<h2>Residual RMS per segment (noise-floor sigmas, before &rarr; after)</h2><table><tr>"
       "<th class=l>segment</th><th>t0&ndash;t1, s</th>";
  for (int c = 0; c < 6; ++c) o << "<th>" << calib::explainChannelName(c) << "</th>";
  o << "</tr>\n";
  for (std::size_t s = 0; s < n; ++s) {
    if (count[s] == 0) continue;
    const calib::Segment& g = r.segments[s];
    o << "<tr><td class=l>" << s + 1 << " " << esc(g.label) << "</td><td>" << num(g.t0, "%.1f")
      << "&ndash;" << num(g.t1, "%.1f") << "</td>";
    for (std::size_t c = 0; c < 6; ++c) {
      const double b = std::sqrt(sum[s][c] / count[s]), a = std::sqrt(sum[s][6 + c] / count[s]);
      o << "<td" << (b > 3 ? " class=bad" : "") << ">" << num(b, "%.1f") << " &rarr; "
        << num(a, "%.1f") << "</td>";
    }
    o << "</tr>\n";
  }
  o << "</table>\n";
}

void windowTable(const char* title, const std::vector<calib::ExplainWindow>& ws,
                 std::ostringstream& o) {
  o << "<h2>" << title << " (" << ws.size() << ")</h2>\n";
  if (ws.empty()) return;
  o << "<table><tr><th>t0, s</th><th>t1, s</th><th class=l>channel</th><th>sigma</th>"
       "<th>mean</th><th class=l>where</th></tr>\n";
  std::vector<calib::ExplainWindow> sorted = ws;
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return std::abs(a.sigma) > std::abs(b.sigma); });
  if (sorted.size() > 200) sorted.resize(200);
  for (const calib::ExplainWindow& w : sorted) {
    o << "<tr><td>" << num(w.t0, "%.1f") << "</td><td>" << num(w.t1, "%.1f") << "</td><td class=l>"
      << calib::explainChannelName(w.channel) << "</td><td>" << num(w.sigma, "%+.1f") << "</td><td>"
      << num(w.mean, "%+.4g") << "</td><td class=l>" << esc(w.reason) << "</td></tr>\n";
  }
  o << "</table>\n";
}

}  // namespace

std::string explainReportHtml(const calib::ExplainResult& r, const std::string& title) {
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>imubench explain: " << esc(title)
    << "</title><style>" << kHtmlReportStyle << "</style></head><body>\n"
    << "<h1>imubench explain: " << esc(title) << "</h1>\n";
  verdict(r, o);
  effects(r, o);
  o << "<h2>Residuals per channel (noise-floor sigmas)</h2><p class=legend><span>grey: baseline"
       "</span><span style='color:#1f5fbf'>blue: after the refit</span><span "
       "style='background:#ffd9a0'>located</span> <span style='background:#ff9c9c'>"
       "unexplained</span></p>\n";
  for (int c = 0; c < 6; ++c) channelPlot(r, c, o);
  segmentTable(r, o);
  windowTable("Located windows (baseline residual beyond the noise floor)", r.located, o);
  windowTable("Unexplained windows (after the refit)", r.unexplained, o);
  o << "<h2>Notes</h2><ul>\n";
  for (const std::string& n : r.notes) o << "<li>" << esc(n) << "</li>\n";
  o << "</ul></body></html>\n";
  return o.str();
}

Status writeExplainReport(const std::string& dir, const calib::ExplainResult& r,
                          const std::string& title) {
  return writeHtmlReport(dir, explainReportHtml(r, title));
}

}  // namespace imubench::io
