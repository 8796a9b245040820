// imubench import-csv FILE [GYRO_FILE] --columns SPEC --units SPEC [--rate HZ | --time COL:UNIT]
//                     [--gravity G] [--latitude DEG] [--height M] [--serial S] [--resample HZ]
//                     [--delimiter D] [--header yes|no] [--skip-bad-rows] --out DIR
// Any logger's text/CSV into an imubench-csv/1 recording without table angles (io/logger_csv.h,
// docs/import.md). Prints the layout found, the timing measured (median interval, jitter,
// gaps) and every bad row at file:line; writes DIR/import.json with the same. Bad rows refuse
// the import (exit 1, nothing written) unless --skip-bad-rows, which leaves each out and
// lists it.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "io/logger_csv.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

struct ImportCsvOptions {
  io::LoggerImportOptions io;
  std::string columns;
  std::string units;
  std::string time;  // COL:UNIT
  std::string delimiter;
  std::string header;
  std::string out;
  std::optional<double> latitude_deg;
  bool no_static_check = false;
};

std::vector<std::pair<std::string, std::string>> keyValues(const std::string& spec,
                                                           const char* option) {
  std::vector<std::pair<std::string, std::string>> kv;
  std::size_t s = 0;
  while (s <= spec.size()) {
    const std::size_t c = spec.find(',', s);
    const std::string item = spec.substr(s, c == std::string::npos ? c : c - s);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size())
      throw CommandFailed(std::string(option) + ": '" + item + "' is not KEY=VALUE", 2);
    kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    if (c == std::string::npos) break;
    s = c + 1;
  }
  return kv;
}

void unitsOf(ImportCsvOptions* o) {
  bool w = false, a = false, t = false;
  std::string why;
  for (const auto& [k, v] : keyValues(o->units, "--units")) {
    io::ColumnUnit* u = k == "w"   ? &o->io.gyro_unit
                        : k == "a" ? &o->io.accel_unit
                        : k == "t" ? &o->io.time_unit
                                   : nullptr;
    if (!u) throw CommandFailed("--units: unknown key '" + k + "' (t, w, a)", 2);
    (k == "w" ? w : k == "a" ? a : t) = true;
    if (!io::parseColumnUnit(k[0], v, u, &why)) throw CommandFailed("--units " + k + ": " + why, 2);
  }
  if (!w || !a) throw CommandFailed("--units needs w=... and a=... (the readings' units)", 2);
  if (!t && !o->io.rate_hz && o->time.empty())
    throw CommandFailed("--units needs t=s|ms|us|ns for the time column", 2);
}

void resolveOptions(ImportCsvOptions* o) {
  for (const auto& [k, v] : keyValues(o->columns, "--columns")) o->io.columns.push_back({k, {v}});
  if (!o->time.empty()) {
    const std::size_t c = o->time.rfind(':');
    if (c == std::string::npos) throw CommandFailed("--time: expected COL:s|ms|us|ns", 2);
    o->io.columns.push_back({"t", {o->time.substr(0, c)}});
    o->units += ",t=" + o->time.substr(c + 1);
  }
  unitsOf(o);
  if (!o->delimiter.empty()) {
    const std::string& d = o->delimiter;
    if (d == "tab" || d == "\\t") {
      o->io.delimiter = '\t';
    } else if (d == "space" || d == "whitespace") {
      o->io.delimiter = ' ';
    } else if (d.size() == 1) {
      o->io.delimiter = d[0];
    } else {
      throw CommandFailed("--delimiter: one character, tab or whitespace", 2);
    }
  }
  if (!o->header.empty()) o->io.header = o->header == "yes";
  if (o->latitude_deg) o->io.latitude_deg = *o->latitude_deg;
  if (!o->latitude_deg && !o->io.gravity_mps2)
    throw CommandFailed("give --gravity G (local gravity, m/s^2) or --latitude DEG", 2);
  if (o->no_static_check) o->io.static_force_tolerance = 0.0;
}

void printReport(const ImportCsvOptions& o, const io::LoggerImport& r) {
  constexpr std::size_t kShown = 50;
  for (std::size_t i = 0; i < r.bad_rows.size() && i < kShown; ++i)
    std::cerr << r.bad_rows[i].where() << ": " << r.bad_rows[i].why << "\n";
  if (r.bad_rows.size() > kShown)
    std::cerr << "... and " << r.bad_rows.size() - kShown << " more bad rows"
              << (r.status.ok ? " (all in import.json)" : "") << "\n";
  if (!r.status.ok) return;
  for (const io::FileLayout& f : r.files)
    std::cout << f.path << ": " << f.data_rows << " data rows, delimiter "
              << (f.delimiter == ' '    ? "whitespace"
                  : f.delimiter == '\t' ? "tab"
                                        : std::string(1, f.delimiter))
              << ", " << (f.header ? "header" : "no header") << ", " << f.skipped_lines
              << " blank/comment lines\n";
  const io::TimingReport& t = r.timing;
  std::printf(
      "timing%s: median interval %.6g s (%.6g Hz), jitter RMS %.3g s, max %.3g s, "
      "intervals %.6g .. %.6g s, %zu gap(s) > 1.5 median\n",
      t.from_rate ? " (from --rate)" : "", t.median_dt_s, t.rate_hz, t.jitter_rms_s, t.jitter_max_s,
      t.min_dt_s, t.max_dt_s, t.gaps.size());
  for (std::size_t i = 0; i < t.gaps.size() && i < kShown; ++i)
    std::printf("  gap before %s:%ld: %.6g s (%.6g .. %.6g)\n", t.gaps[i].file.c_str(),
                t.gaps[i].line, t.gaps[i].t1 - t.gaps[i].t0, t.gaps[i].t0, t.gaps[i].t1);
  if (!r.bad_rows.empty())
    std::cout << r.bad_rows.size() << " bad row(s) left out (--skip-bad-rows), listed above\n";
  for (const std::string& n : r.notes) std::cout << "note: " << n << "\n";
  if (!o.latitude_deg)
    std::cout << "note: no --latitude: meta.json says 0 deg (give it for navigation, alignment "
                 "and the Earth-rate checks)\n";
  std::cout
      << "wrote " << r.recording.imu.size() << " samples to " << o.out
      << " (imubench-csv/1, no table angles; report in import.json)\nnext: imubench calibrate "
      << o.out << " --method scalar (static poses and rotations, no table)\n";
}

void runImportCsv(ImportCsvOptions o) {
  resolveOptions(&o);
  const io::LoggerImport r = io::importLogger(o.io);
  printReport(o, r);
  if (!r.status.ok) throw CommandFailed(r.status.message + "; nothing written");
  if (Status st = io::writeRecording(o.out, r.recording); !st.ok) throw CommandFailed(st.message);
  const std::string report = (std::filesystem::path(o.out) / "import.json").string();
  const std::string text = io::importReportJson(o.io, r);
  std::FILE* f = std::fopen(report.c_str(), "wb");
  if (!f || std::fwrite(text.data(), 1, text.size(), f) != text.size() || std::fclose(f) != 0)
    throw CommandFailed(report + ": cannot write");
}

}  // namespace

void addImportCsvCommand(CLI::App& app) {
  auto opt = std::make_shared<ImportCsvOptions>();
  CLI::App* sub = app.add_subcommand(
      "import-csv", "a logger's text/CSV file (or accelerometer + gyro files) into imubench-csv/1");
  sub->add_option("file", opt->io.path, "the logger's file (accelerometer and gyro columns)")
      ->required();
  sub->add_option("gyro_file", opt->io.gyro_path,
                  "the gyro file when the gyro is logged apart (merged on time)");
  sub->add_option("--columns", opt->columns,
                  "KEY=COL,...: t, wx, wy, wz, ax, ay, az, temp (optional), gt (gyro file time, "
                  "default t); COL a header name or a 1-based index")
      ->required();
  sub->add_option("--units", opt->units,
                  "t=s|ms|us|ns, w=rad/s|deg/s|rad|deg, a=m/s^2|g|m/s; counts: count:K:U (K "
                  "units U per count) or lsb:N:U (N counts per U); g = 9.80665 m/s^2")
      ->required();
  auto* rate = sub->add_option("--rate", opt->io.rate_hz, "no time column: rows at this rate, Hz");
  sub->add_option("--time", opt->time, "COL:s|ms|us|ns: the time column and its unit")
      ->excludes(rate);
  sub->add_option("--gravity", opt->io.gravity_mps2,
                  "local gravity, m/s^2 (meta.json site.gravity_mps2)");
  sub->add_option("--latitude", opt->latitude_deg, "site latitude, deg (default 0 with --gravity)");
  sub->add_option("--height", opt->io.height_m, "site height, m (default 0)");
  sub->add_option("--serial", opt->io.serial, "IMU serial for meta.json")->capture_default_str();
  sub->add_option("--resample", opt->io.resample_hz,
                  "resample to this rate, Hz (area-preserving); default: the stamps as logged");
  sub->add_option("--delimiter", opt->delimiter, "',' ';' tab whitespace ...; default: detected");
  sub->add_option("--header", opt->header, "yes|no; default: detected")
      ->check(CLI::IsMember({"yes", "no"}));
  sub->add_flag("--skip-bad-rows", opt->io.skip_bad_rows,
                "leave bad rows out (each listed) instead of refusing the import");
  sub->add_flag("--no-static-check", opt->no_static_check,
                "do not check |f| against gravity on rows where the gyro is still");
  sub->add_option("--out", opt->out, "output recording directory")->required();
  sub->callback([opt] { runImportCsv(*opt); });
}

}  // namespace imubench::tools
