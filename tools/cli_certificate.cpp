// imubench certificate RUN [--db FILE] [--out DIR]
// imubench certificate DIR --coefficients C.json [--explain E.json] [--out DIR]
//
// The calibration certificate (io/certificate.h): DIR/certificate.html, one self-contained
// page (no script, no network resource) that prints to PDF from a browser.
//   RUN (N or run:N of the daemon's store, tools/cli_store.h): everything from the store: the
//       run's IMU serial, bench, plan (its stored text's SHA-256), the recording's checksums
//       (of the imubench-csv/1 files `imubench export RUN --csv` writes, bit-exact), the stored
//       coefficients with sigmas, what the plan could not observe, the table errors, the
//       temperature/dT/dt envelope of the recording, the stored explain report and the verdict
//       against the bench's acceptance limits.
//   DIR (a recording directory, offline): the coefficients from --coefficients, the explain
//       report from --explain; the checksums of DIR's files. No verdict: acceptance limits are
//       the bench's and are applied to runs of the store; the page says so.
// A run without stored coefficients still gets a certificate that says what is missing (and
// the exit code is 0 only with coefficients; without them 1 after writing, so a script does
// not hand out an empty certificate by accident).
#include <unistd.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "imubench_build_id.h"
#include "io/certificate.h"
#include "io/truth_file.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

using nlohmann::json;

struct CertificateOptions {
  std::string run_or_dir;
  std::string db;
  std::string out = ".";     // the page goes to OUT/certificate.html
  std::string coefficients;  // offline: the coefficient file
  std::string explain;       // offline: an imubench-explain/1 report
};

// The recording's files as `imubench export RUN --csv` writes them, checksummed in a private
// temporary directory that is removed afterwards.
std::vector<io::FileChecksum> storedRecordingChecksums(const io::Recording& rec) {
  namespace fs = std::filesystem;
  std::string tmpl = (fs::temp_directory_path() / "imubench-cert-XXXXXX").string();
  if (::mkdtemp(tmpl.data()) == nullptr)
    throw CommandFailed("cannot create a temporary directory for the recording's checksums");
  const std::string dir = tmpl + "/recording";
  const Status st = io::writeRecording(dir, rec);
  Result<std::vector<io::FileChecksum>> sums;
  if (st.ok) sums = io::directoryChecksums(dir);
  std::error_code ec;
  fs::remove_all(tmpl, ec);
  if (!st.ok) throw CommandFailed(st.message);
  if (!sums.status.ok) throw CommandFailed(sums.status.message);
  return sums.value;
}

std::optional<calib::CoefficientReport> coefficientsOf(const json& j, const std::string& where) {
  calib::CoefficientReport c;
  std::string why;
  if (!calib::fromJson(j, &c, &why)) throw CommandFailed(where + ": " + why);
  return c;
}

// The stored report's "estimate.unobservable" (the plan's null space by name).
std::vector<std::string> unobservableOf(const json& report) {
  std::vector<std::string> out;
  if (!report.is_object() || !report.contains("estimate")) return out;
  for (const json& n : report["estimate"].value("unobservable", json::array()))
    if (n.is_string()) out.push_back(n.get<std::string>());
  return out;
}

io::CertificateInput fromStore(const CertificateOptions& o, std::int64_t id) {
  io::CertificateInput in;
  const io::Recording rec = loadStoredRun(id, o.db);
  const StoredRunState st = loadRunState(o.db, id);
  in.run_id = std::to_string(id);
  in.source = "run " + in.run_id + " of " + o.db;
  in.run_state = st.state;
  in.imu_serial = st.imu_serial.empty() ? rec.imu_serial : st.imu_serial;
  in.bench_name = st.bench_name;
  in.plan_name = st.plan_name;
  if (!st.plan_toml.empty()) in.plan_sha256 = io::sha256Hex(st.plan_toml);
  in.started_utc = utcTime(st.started_unix_s);
  if (st.finished_unix_s) in.finished_utc = utcTime(*st.finished_unix_s);
  in.recording_files = storedRecordingChecksums(rec);
  in.checksum_note = "SHA-256 of the imubench-csv/1 files as `imubench export " + in.run_id +
                     " --csv DIR` writes them (bit-exact); check with `sha256sum DIR/*`.";
  in.envelope = io::temperatureEnvelope(rec.imu);
  std::map<std::string, json> k;  // newest result of each kind
  for (const StoredResultRow& r : loadStoredResults(o.db, id, std::nullopt))
    k[r.kind] = json::parse(r.json, nullptr, false);
  if (k.count("coefficients"))
    in.coefficients = coefficientsOf(k["coefficients"], in.source + ": stored coefficients");
  if (k.count("report")) {
    in.method = k["report"].value("method", std::string());
    in.calibrated_by = k["report"].value("software", std::string());
    in.unobservable = unobservableOf(k["report"]);
  }
  if (k.count("explain")) in.explain = k["explain"];
  if (k.count("verdict")) in.verdict = k["verdict"];
  return in;
}

io::CertificateInput fromDirectory(const CertificateOptions& o) {
  if (o.coefficients.empty())
    throw CommandFailed(o.run_or_dir + ": a recording directory needs --coefficients FILE", 2);
  io::CertificateInput in;
  const ResolvedRecording r = loadRunOrDir(o.run_or_dir, o.db);
  in.source = o.run_or_dir;
  in.imu_serial = r.recording.imu_serial;
  const auto sums = io::directoryChecksums(o.run_or_dir);
  if (!sums.status.ok) throw CommandFailed(sums.status.message);
  in.recording_files = sums.value;
  in.checksum_note = "SHA-256 of the files of " + o.run_or_dir + "; check with `sha256sum`.";
  in.envelope = io::temperatureEnvelope(r.recording.imu);
  json c;
  if (const Status st = io::readJsonFile(o.coefficients, &c); !st.ok)
    throw CommandFailed(st.message);
  in.coefficients = coefficientsOf(c, o.coefficients);
  in.method = "(offline: " + o.coefficients + ")";
  if (!o.explain.empty()) {
    if (const Status st = io::readJsonFile(o.explain, &in.explain); !st.ok)
      throw CommandFailed(st.message);
    if (in.explain.value("format", std::string()) != "imubench-explain/1")
      throw CommandFailed(o.explain + ": not an imubench-explain/1 report", 2);
  }
  return in;
}

void runCertificate(const CertificateOptions& o) {
  std::error_code ec;
  const bool is_dir = std::filesystem::is_directory(o.run_or_dir, ec);
  const std::optional<std::int64_t> id = is_dir ? std::nullopt : parseRunId(o.run_or_dir);
  if (!is_dir && !id)
    throw CommandFailed("'" + o.run_or_dir + "' is neither a recording directory nor a run id", 2);
  if (id && (!o.coefficients.empty() || !o.explain.empty()))
    throw CommandFailed(
        "--coefficients and --explain are for a recording directory; a run "
        "takes them from the store",
        2);
  io::CertificateInput in = id ? fromStore(o, *id) : fromDirectory(o);
  in.certificate_by = IMUBENCH_BUILD_ID;
  in.generated_utc = utcTime(static_cast<double>(std::time(nullptr)));
  if (const Status st = io::writeCertificate(o.out, io::certificateHtml(in)); !st.ok)
    throw CommandFailed(st.message);
  std::cout << "certificate written to " << o.out << "/certificate.html\n";
  if (!in.coefficients)
    throw CommandFailed(in.source +
                        ": no coefficients stored: the certificate says so and "
                        "certifies nothing");
}

}  // namespace

void addCertificateCommand(CLI::App& app) {
  auto o = std::make_shared<CertificateOptions>();
  CLI::App* sub = app.add_subcommand(
      "certificate",
      "a self-contained HTML calibration certificate (OUT/certificate.html; prints to PDF from "
      "a browser) of a stored run, or of a recording directory with --coefficients");
  sub->add_option("RUN_OR_DIR", o->run_or_dir, "run id (N or run:N) or recording directory")
      ->required();
  sub->add_option("--out", o->out, "directory for certificate.html (default: .)");
  sub->add_option("--coefficients", o->coefficients,
                  "DIR: the coefficient file (interchange JSON) the certificate states");
  sub->add_option("--explain", o->explain, "DIR: an imubench-explain/1 report (explain --json)");
  addStoreOption(*sub, &o->db);
  sub->callback([o] { runCertificate(*o); });
}

}  // namespace imubench::tools
