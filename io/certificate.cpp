#include "io/certificate.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "calib/thermal_model.h"
#include "calib/truth_comparison.h"
#include "io/file_io.h"
#include "io/html_report.h"

namespace imubench::io {
namespace {

using nlohmann::json;

std::string esc(const std::string& s) {
  return htmlEscape(s);
}
std::string num(double v, const char* fmt = "%.4g") {
  return htmlNumber(v, fmt);
}
std::string orDash(const std::string& s) {
  return s.empty() ? "&ndash;" : esc(s);
}

std::string hex(const unsigned char* d, unsigned n) {
  static const char* const kDigits = "0123456789abcdef";
  std::string out;
  for (unsigned i = 0; i < n; ++i) {
    out += kDigits[d[i] >> 4];
    out += kDigits[d[i] & 15];
  }
  return out;
}

// The certificate's own print layout on top of the reports' style.
constexpr const char* kCertificateStyle =
    "h1{margin-bottom:0.2em}h2{border-bottom:1px solid #999;margin-top:1.4em}"
    ".mono{font-family:monospace;font-size:85%}.note{color:#555;font-size:90%}"
    ".sign td{height:3em;min-width:14em;text-align:left}"
    "@page{size:A4;margin:15mm}@media print{body{margin:0}section{break-inside:avoid}}";

std::string section(const char* id, const char* heading, const std::string& body) {
  return std::string("<section id=\"") + id + "\"><h2>" + heading + "</h2>\n" + body +
         "</section>\n";
}

std::string row2(const std::string& k, const std::string& v) {
  return "<tr><th class=\"l\">" + k + "</th><td class=\"l\">" + v + "</td></tr>\n";
}

std::string identitySection(const CertificateInput& in) {
  std::string t = "<table>\n";
  t += row2("IMU serial", orDash(in.imu_serial));
  t += row2("Bench", orDash(in.bench_name));
  t += row2("Plan", orDash(in.plan_name));
  t += row2("Plan text SHA-256", in.plan_sha256.empty()
                                     ? "&ndash; (not stored)"
                                     : "<span class=\"mono\">" + esc(in.plan_sha256) + "</span>");
  t += row2("Run", in.run_id.empty() ? "&ndash; (offline: " + esc(in.source) + ")"
                                     : esc(in.run_id) + " (" + orDash(in.run_state) + ")");
  t += row2("Source", orDash(in.source));
  t += row2("Started / finished (UTC)", orDash(in.started_utc) + " / " + orDash(in.finished_utc));
  t += row2("Calibration method", orDash(in.method));
  return section("identity", "Identity", t + "</table>\n");
}

std::string recordingSection(const CertificateInput& in) {
  std::string b;
  if (in.recording_files.empty()) {
    b = "<p class=\"bad\">No recording files: no checksums.</p>\n";
  } else {
    b = "<table><tr><th class=\"l\">file</th><th>bytes</th><th class=\"l\">SHA-256</th></tr>\n";
    for (const FileChecksum& f : in.recording_files) {
      b += "<tr><td class=\"l\">" + esc(f.name) + "</td><td>" + std::to_string(f.bytes) +
           "</td><td class=\"l mono\">" + esc(f.sha256_hex) + "</td></tr>\n";
    }
    b += "</table>\n";
  }
  if (!in.checksum_note.empty()) b += "<p class=\"note\">" + esc(in.checksum_note) + "</p>\n";
  return section("recording", "Recording checksums", b);
}

// A coefficient in its display unit (calib/truth_comparison.h): scales as ppm of (s - 1).
double inUnit(const std::string& name, double si) {
  const calib::DisplayUnit u = calib::displayUnit(name);
  const double v = name.find(".scale.") != std::string::npos ? si - 1.0 : si;
  return v / u.si_per_unit;
}

std::string unitLabel(const std::string& name) {
  const std::string l = calib::displayUnit(name).label;
  if (name.find(".scale.") != std::string::npos) return "ppm (scale &minus; 1)";
  return l.empty() ? "SI" : esc(l);
}

// The sensor coefficients (table_errors false) or the table's errors (true), one row each.
std::string coefficientTable(const calib::CoefficientReport& c, bool table_errors) {
  const std::vector<std::string> names = calib::flatNames(c.values);
  const std::vector<double> values = calib::flatValues(c.values);
  std::string t =
      "<table><tr><th class=\"l\">parameter</th><th>value</th><th>1-sigma</th>"
      "<th class=\"l\">unit</th><th class=\"l\">status</th></tr>\n";
  for (std::size_t i = 0; i < names.size(); ++i) {
    const bool is_table = names[i].rfind("table.", 0) == 0;
    if (is_table != table_errors) continue;
    const auto u = c.uncertainty.find(names[i]);
    const bool observable = u == c.uncertainty.end() || u->second.observable;
    const bool has_sigma = u != c.uncertainty.end() && u->second.sigma.has_value();
    const double sigma = has_sigma ? u->second.sigma.value_or(0.0) : 0.0;
    const double unit_si = calib::displayUnit(names[i]).si_per_unit;
    std::string status =
        !observable ? "<span class=\"bad\">held (not observable)</span>"
        : has_sigma ? "estimated"
                    : (table_errors ? "held at this value (not estimated)" : "no sigma stored");
    t += "<tr><td class=\"l\">" + esc(names[i]) + "</td><td>" +
         num(inUnit(names[i], values[i]), "%.4f") + "</td><td>" +
         (has_sigma && observable ? num(sigma / unit_si, "%.4f") : std::string("&ndash;")) +
         "</td><td class=\"l\">" + unitLabel(names[i]) + "</td><td class=\"l\">" + status +
         "</td></tr>\n";
  }
  return t + "</table>\n";
}

std::string coefficientsSection(const CertificateInput& in) {
  if (!in.coefficients)
    return section("coefficients", "Coefficients",
                   "<p class=\"bad\">No coefficients stored for this run.</p>\n");
  return section("coefficients", "Coefficients",
                 "<p class=\"note\">Sensor model reading = diag(scale) (M input &minus; bias) "
                 "(interchange.md); 1-sigma from the fit's covariance.</p>\n" +
                     coefficientTable(*in.coefficients, false));
}

std::string observabilitySection(const CertificateInput& in) {
  std::vector<std::string> held = in.unobservable;
  if (in.coefficients) {
    for (const auto& [name, u] : in.coefficients->uncertainty)
      if (!u.observable && std::find(held.begin(), held.end(), name) == held.end())
        held.push_back(name);
  }
  std::string b;
  if (!in.coefficients && held.empty()) {
    b = "<p class=\"bad\">Not known: no coefficients stored.</p>\n";
  } else if (held.empty()) {
    b = "<p class=\"ok\">Every parameter of the model was observable by the plan.</p>\n";
  } else {
    b = "<p>The plan could not observe these parameters; they are held at their start values "
        "and are <b>not measured</b> by this calibration:</p>\n<ul>\n";
    for (const std::string& n : held) b += "<li class=\"mono\">" + esc(n) + "</li>\n";
    b += "</ul>\n";
  }
  return section("observability", "What was observable", b);
}

std::string tableErrorsSection(const CertificateInput& in) {
  if (!in.coefficients)
    return section("table-errors", "Table-error budget",
                   "<p class=\"bad\">Not known: no coefficients stored.</p>\n");
  return section(
      "table-errors", "Table-error budget",
      "<p class=\"note\">The bench's geometric errors (base tilt, axis nonorthogonality, "
      "mounting, encoder zeros; interchange.md). An estimated one carries its 1-sigma, which "
      "the coefficients' sigmas include; a held one was fixed at the value shown (a table "
      "survey or zero) and its own error is not in the coefficients' sigmas.</p>\n" +
          coefficientTable(*in.coefficients, true));
}

std::string envelopeSection(const CertificateInput& in) {
  const TemperatureEnvelope& e = in.envelope;
  if (!e.recorded)
    return section("envelope", "Temperature envelope",
                   "<p class=\"bad\">The recording carries no IMU temperature: the range the "
                   "coefficients hold over is not known.</p>\n");
  std::string t = "<table>\n";
  t += row2("IMU temperature",
            num(e.temp_min_c, "%.2f") + " .. " + num(e.temp_max_c, "%.2f") + " &deg;C");
  t += row2("dT/dt (over " + num(e.rate_window_s, "%.0f") + " s)",
            num(e.rate_min_c_per_s * 60.0, "%.3f") + " .. " +
                num(e.rate_max_c_per_s * 60.0, "%.3f") + " &deg;C/min");
  t += "</table>\n<p><b>Outside this envelope the model extrapolates</b>: the coefficients are "
       "measured only for the temperatures and rates of change listed here.</p>\n";
  return section("envelope", "Temperature and dT/dt envelope", t);
}

std::string compact(const json& v) {
  if (v.is_number()) return num(v.get<double>());
  if (!v.is_array()) return v.is_null() ? "&ndash;" : esc(v.dump());
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + compact(v[i]);
  return out + "]";
}

// e's key as an array (empty when absent or not an array).
json arrayAt(const json& e, const char* key) {
  return e.contains(key) && e[key].is_array() ? e[key] : json::array();
}

std::string acceptedEffects(const json& e) {
  const json accepted = arrayAt(e, "accepted");
  if (accepted.empty()) return "<p>No effect beyond the model was accepted.</p>\n";
  std::string t =
      "<table><tr><th class=\"l\">effect</th><th class=\"l\">parameters &plusmn; 1-sigma</th>"
      "<th>&Delta;BIC</th></tr>\n";
  for (const json& a : accepted) {
    const json none = json::object();
    const json& sigma = a.contains("sigma") ? a["sigma"] : none;
    const json& parameters = a.contains("parameters") ? a["parameters"] : none;
    std::string p;
    for (const auto& [name, v] : parameters.items()) {
      p += esc(name) + " = " + compact(v);
      if (sigma.contains(name)) p += " &plusmn; " + compact(sigma[name]);
      p += "<br>";
    }
    t += "<tr><td class=\"l\">" + esc(a.value("effect", std::string("?"))) +
         "</td><td class=\"l\">" + p + "</td><td>" + num(a.value("delta_bic", 0.0), "%.1f") +
         "</td></tr>\n";
  }
  return t + "</table>\n";
}

std::string findingsSection(const CertificateInput& in) {
  const json& e = in.explain;
  if (!e.is_object() || e.value("format", std::string()) != "imubench-explain/1")
    return section("findings", "Missing-physics findings",
                   "<p class=\"bad\">No missing-physics analysis (imubench explain) stored: "
                   "whether the model leaves physics out of this recording was not checked."
                   "</p>\n");
  const json base = e.contains("baseline") ? e["baseline"] : json::object();
  std::string b = "<p>Normalised residual RMS (1 = the noise floor of the static holds): " +
                  num(base.value("normalised_rms", NAN), "%.3g") + " with the " +
                  esc(base.value("method", std::string("?"))) + " model, " +
                  num(e.value("normalised_rms_after", NAN), "%.3g") +
                  " with the accepted effects.</p>\n";
  b += acceptedEffects(e);
  const std::size_t unexplained = arrayAt(e, "unexplained").size();
  b += unexplained == 0 ? "<p class=\"ok\">No window is left unexplained.</p>\n"
                        : "<p class=\"bad\">" + std::to_string(unexplained) +
                              " window(s) where the residual stays above the noise floor and "
                              "no effect of the library explains it.</p>\n";
  return section("findings", "Missing-physics findings", b);
}

std::string verdictRows(const json& rows) {
  std::string t =
      "<table><tr><th class=\"l\">parameter</th><th>value</th><th>limit</th><th "
      "class=\"l\">unit</th><th class=\"l\">result</th></tr>\n";
  for (const json& r : rows) {
    if (!r.is_object()) continue;
    const bool has = r.contains("value") && r["value"].is_number();
    const bool pass = r.value("pass", false);
    t += "<tr><td class=\"l\">" + esc(r.value("parameter", std::string("?"))) + "</td><td>" +
         (has ? num(r["value"].get<double>(), "%.4f") : std::string("&ndash;")) + "</td><td>" +
         num(r.value("limit", NAN), "%.4f") + "</td><td class=\"l\">" +
         esc(r.value("unit", std::string())) + "</td><td class=\"l " +
         (pass ? "ok\">pass" : "bad\">FAIL") +
         (has ? std::string() : ": " + esc(r.value("why", std::string()))) + "</td></tr>\n";
  }
  return t + "</table>\n";
}

std::string verdictSection(const CertificateInput& in) {
  const json& v = in.verdict;
  if (!v.is_object())
    return section("verdict", "Verdict",
                   "<p class=\"bad\"><b>NO VERDICT</b>: no acceptance verdict stored (the "
                   "bench's [acceptance] limits are applied when the daemon calibrates a "
                   "run).</p>\n");
  const json pass = v.value("pass", json());
  std::string b =
      !pass.is_boolean()
          ? "<p class=\"bad\"><b>NO VERDICT</b> (" + esc(v.value("why", std::string("-"))) +
                ")</p>\n"
          : (pass.get<bool>() ? "<p class=\"ok\"><b>PASS</b>" : "<p class=\"bad\"><b>FAIL</b>") +
                std::string(" against the bench's acceptance limits.</p>\n");
  if (pass.is_boolean() && v.contains("why"))
    b += "<p>" + esc(v.value("why", std::string())) + "</p>\n";
  const json rows = arrayAt(v, "rows"), notes = arrayAt(v, "notes");
  if (!rows.empty()) b += verdictRows(rows);
  for (const json& n : notes)
    if (n.is_string()) b += "<p class=\"note\">" + esc(n.get<std::string>()) + "</p>\n";
  return section("verdict", "Verdict", b);
}

std::string softwareSection(const CertificateInput& in) {
  std::string t = "<table>\n";
  t += row2("Calibrated by", in.calibrated_by.empty()
                                 ? std::string("not recorded (an offline recording, or a run "
                                               "stored before reports carried the software)")
                                 : in.calibrated_by);
  t += row2("Certificate by", orDash(in.certificate_by));
  t += row2("Certificate generated (UTC)", orDash(in.generated_utc));
  t += "</table>\n<table class=\"sign\"><tr><th class=\"l\">Checked by</th><td></td>"
       "<th class=\"l\">Date</th><td></td></tr></table>\n";
  return section("software", "Software and signature", t);
}

}  // namespace

std::string sha256Hex(const std::string& bytes) {
  unsigned char d[EVP_MAX_MD_SIZE];
  unsigned n = 0;
  EVP_Digest(bytes.data(), bytes.size(), d, &n, EVP_sha256(), nullptr);
  return hex(d, n);
}

Result<std::vector<FileChecksum>> directoryChecksums(const std::string& dir) {
  namespace fs = std::filesystem;
  Result<std::vector<FileChecksum>> r;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    std::string bytes;
    if (const Status st = readWholeFile(e.path().string(), &bytes); !st.ok) {
      r.status = st;
      r.value.clear();
      return r;
    }
    r.value.push_back({e.path().filename().string(), bytes.size(), sha256Hex(bytes)});
  }
  if (ec) {
    r.status = Status::Error(dir + ": cannot list: " + ec.message());
    r.value.clear();
    return r;
  }
  std::sort(r.value.begin(), r.value.end(),
            [](const FileChecksum& a, const FileChecksum& b) { return a.name < b.name; });
  r.status = Status::Ok();
  return r;
}

TemperatureEnvelope temperatureEnvelope(const nav::ImuSamples& imu,
                                        const TemperatureEnvelopeOptions& options) {
  TemperatureEnvelope e;
  e.rate_window_s = options.rate_window_s;
  calib::TemperatureRateOptions ro;
  ro.window_s = options.rate_window_s;
  const std::vector<double> rates = calib::temperatureRates(imu, ro);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    if (!std::isfinite(imu[i].temp_c)) continue;
    const double t = imu[i].temp_c, r = i < rates.size() ? rates[i] : 0.0;
    if (!e.recorded) {
      e.recorded = true;
      e.temp_min_c = e.temp_max_c = t;
      e.rate_min_c_per_s = e.rate_max_c_per_s = r;
      continue;
    }
    e.temp_min_c = std::min(e.temp_min_c, t);
    e.temp_max_c = std::max(e.temp_max_c, t);
    e.rate_min_c_per_s = std::min(e.rate_min_c_per_s, r);
    e.rate_max_c_per_s = std::max(e.rate_max_c_per_s, r);
  }
  return e;
}

std::string certificateHtml(const CertificateInput& in) {
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" +
                  esc(in.title + " " + in.imu_serial) + "</title><style>" + kHtmlReportStyle +
                  kCertificateStyle + "</style></head><body>\n<h1>" + esc(in.title) +
                  "</h1>\n<p>IMU <b>" + orDash(in.imu_serial) + "</b>" +
                  (in.run_id.empty() ? "" : ", run " + esc(in.run_id)) + "</p>\n";
  h += identitySection(in);
  h += recordingSection(in);
  h += coefficientsSection(in);
  h += observabilitySection(in);
  h += tableErrorsSection(in);
  h += envelopeSection(in);
  h += findingsSection(in);
  h += verdictSection(in);
  h += softwareSection(in);
  return h + "</body></html>\n";
}

Status writeCertificate(const std::string& dir, const std::string& html) {
  return writeHtmlFile(dir, "certificate.html", html);
}

}  // namespace imubench::io
