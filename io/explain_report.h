// The model-discrepancy analysis's report for people: DIR/report.html, one self-contained file
// (inline SVG and CSS, no script, no network) with
//   - the verdict: baseline, normalised residual RMS before and after, per-channel RMS against
//     the noise floor;
//   - the accepted effects with parameters and sigmas and their test statistics; the rejected
//     alternatives and why; the unseparable groups and the motion that would separate them;
//   - per channel, the binned residual (in noise-floor sigmas) against time before and after
//     the refit, with the located windows (orange) and the unexplained ones (red) highlighted;
//   - per segment and channel, the residual RMS in sigmas before and after;
//   - the windows themselves.
// Also written by the daemon next to the stored JSON report when it runs the analysis.
#pragma once

#include <string>

#include "base/status.h"
#include "calib/explain/explain.h"

namespace imubench::io {

// The HTML text (title: what was analysed, e.g. the recording's path or "run 12").
std::string explainReportHtml(const calib::ExplainResult& result, const std::string& title);

// Creates DIR when needed and writes DIR/report.html (temp file + rename).
Status writeExplainReport(const std::string& dir, const calib::ExplainResult& result,
                          const std::string& title);

}  // namespace imubench::io
