// The small shared part of the project's self-contained HTML reports (io/explain_report,
// io/thermal_report): escaping, number formatting, the common style sheet and writing
// DIR/report.html. One file, inline SVG and CSS, no script, no network.
#pragma once

#include <string>

#include "base/status.h"

namespace imubench::io {

// Text escaped for HTML element content and quoted attribute values.
std::string htmlEscape(const std::string& s);

// printf-formatted number; "&ndash;" for NaN and infinities.
std::string htmlNumber(double v, const char* fmt = "%.4g");

// The reports' CSS (tables, .ok/.bad verdict colours, SVG frame, legend spans).
extern const char* const kHtmlReportStyle;

// Creates DIR when needed and writes DIR/report.html (temp file + rename). A DIR that cannot
// be created or written is named in the error.
Status writeHtmlReport(const std::string& dir, const std::string& html);
// The same for DIR/name.
Status writeHtmlFile(const std::string& dir, const std::string& name, const std::string& html);

}  // namespace imubench::io
