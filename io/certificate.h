// The calibration certificate (issue 29 item 4): one self-contained HTML page a lab signs and
// hands to the customer, printable to PDF from a browser. No script, no network resource: the
// style sheet is inline (io/html_report.h) and nothing is loaded from anywhere.
//
// Sections (each an element with this id, so a reader or a test can find it):
//   identity      IMU serial, bench, plan (name and SHA-256 of its text), run, times
//   recording     the recording's files with their sizes and SHA-256 checksums
//   coefficients  every coefficient with its 1-sigma, in display units
//   observability what the plan could not observe (held at its start value, not measured)
//   table-errors  the table-error budget: each geometric error, estimated or held, its sigma
//   envelope      the temperature and dT/dt range the recording covered (outside it the
//                 model extrapolates)
//   findings      the missing-physics analysis (imubench-explain/1): accepted effects,
//                 residuals against the noise floor, unexplained windows
//   verdict       the verdict against the bench's acceptance limits, row by row
//   software      the software (version and commit) that calibrated and that wrote this page
// A section without data says so ("not stored", "not recorded"); nothing is left out silently.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/bench_truth.h"
#include "nav/imu_sample.h"

namespace imubench::io {

// One file of a recording and its checksum.
struct FileChecksum {
  std::string name;  // file name inside the recording directory
  std::uintmax_t bytes = 0;
  std::string sha256_hex;
};

// SHA-256 of every regular file of the directory, sorted by name. An unreadable directory or
// file is named in the error.
Result<std::vector<FileChecksum>> directoryChecksums(const std::string& dir);

// SHA-256 of a text (e.g. the plan file as stored), lower-case hex.
std::string sha256Hex(const std::string& bytes);

// The temperature and dT/dt range a recording covered.
struct TemperatureEnvelope {
  bool recorded = false;  // false: the recording carries no temperature
  double temp_min_c = 0.0, temp_max_c = 0.0;
  double rate_min_c_per_s = 0.0, rate_max_c_per_s = 0.0;  // dT/dt
  double rate_window_s = 0.0;  // the window dT/dt was taken over (calib/thermal_model.h)
};

struct TemperatureEnvelopeOptions {
  // dT/dt window (s): the least-squares slope over this span, as `apply` and `thermal fit`
  // take it (calib::TemperatureRateOptions), so the envelope is in their terms.
  double rate_window_s = 60.0;
};

TemperatureEnvelope temperatureEnvelope(const nav::ImuSamples& imu,
                                        const TemperatureEnvelopeOptions& options = {});

// Everything the certificate shows; the CLI gathers it from the store or from files.
struct CertificateInput {
  std::string title = "IMU calibration certificate";
  std::string imu_serial;
  std::string source;  // where it came from: "run 7 of /var/lib/imubench/imubench.db", a path
  std::string run_id;  // "7", or empty (offline)
  std::string run_state;
  std::string bench_name;
  std::string plan_name;
  std::string plan_sha256;  // of the plan text as stored; empty when not known
  std::string started_utc, finished_utc;
  std::string method;  // direct | indirect | pipeline | scalar
  std::vector<FileChecksum> recording_files;
  std::string checksum_note;  // how the checksums were taken (e.g. "as `imubench export` writes")
  // The coefficient file (interchange.md); absent: no coefficients stored.
  std::optional<calib::CoefficientReport> coefficients;
  std::vector<std::string> unobservable;  // parameters the plan could not observe (stored report)
  TemperatureEnvelope envelope;
  nlohmann::json explain;  // imubench-explain/1, or null when none
  nlohmann::json verdict;  // the stored acceptance verdict (results RUN), or null when none
  // The software that calibrated (the daemon's build, from the stored report; empty for an
  // offline recording or a run stored before reports carried it) and the one writing the page;
  // each "imubench VERSION (git COMMIT)".
  std::string calibrated_by;
  std::string certificate_by;
  std::string generated_utc;
};

// The whole page.
std::string certificateHtml(const CertificateInput& in);

// Writes DIR/certificate.html (DIR created when needed; temp file + rename).
Status writeCertificate(const std::string& dir, const std::string& html);

}  // namespace imubench::io
