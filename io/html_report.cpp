#include "io/html_report.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace imubench::io {

std::string htmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '&':
        o += "&amp;";
        break;
      case '"':
        o += "&quot;";
        break;
      case '\'':
        o += "&#39;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string htmlNumber(double v, const char* fmt) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[64];
  std::snprintf(b, sizeof(b), fmt, v);
  return b;
}

const char* const kHtmlReportStyle =
    "body{font-family:sans-serif;margin:2em;max-width:1100px;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}"
    "td,th{border:1px solid #ccc;padding:2px 8px;text-align:right;font-size:90%}"
    "th{background:#eee}td.l,th.l{text-align:left}"
    ".ok{color:#060}.bad{color:#a00}svg{background:#fafafa;border:1px solid #ddd}"
    ".legend span{display:inline-block;margin-right:1.5em}";

Status writeHtmlReport(const std::string& dir, const std::string& html) {
  return writeHtmlFile(dir, "report.html", html);
}

Status writeHtmlFile(const std::string& dir, const std::string& name, const std::string& html) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Status::Error(dir + ": cannot create the report directory: " + ec.message());
  const std::string path = dir + "/" + name, tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) return Status::Error(tmp + ": cannot create: " + std::strerror(errno));
  const bool ok = std::fwrite(html.data(), 1, html.size(), f) == html.size();
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    return Status::Error(tmp + ": write error");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) return Status::Error(path + ": cannot replace: " + ec.message());
  return Status::Ok();
}

}  // namespace imubench::io
