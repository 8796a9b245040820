// imubench results RUN [--db PATH] [--json] [--truth T.json] [--coefficients FILE]
// imubench results --serial S [--db PATH] [--json]
//
// The calibration results the daemon stored for a run (daemon/online_engine.h): the verdict
// against the bench file's acceptance limits, the coefficients with sigmas, what the plan could
// not observe, and the missing-physics analysis (its accepted effects, residual RMS before and
// after against the noise floor, unexplained windows). --truth compares the stored coefficients
// with a known truth (a simulated bench) per parameter against 3 arcsec / 10 ppm / 2 sigma, the
// truth put into the frame the method refers to (gyro-referenced for indirect and pipeline).
// --coefficients writes the stored coefficient file
// (interchange.md). --serial lists an IMU's history: every calibrated run with its temperature and
// verdict, and every temperature point of its thermal runs (one direct calibration per point,
// at the point's mean IMU temperature). The store is read through imubench-store
// (tools/cli_store.h).
//
// Exit codes of `results RUN` (the verdict; scripts branch on them):
//   0  PASS          the stored verdict passes (and with --truth every parameter is within
//                    its target)
//   4  FAIL          a parameter is outside its acceptance limit (or, with --truth, outside
//                    its target)
//   5  undetermined  no verdict: no [acceptance] limits, the calibration failed, a limited
//                    parameter was not determined, or (--truth) a parameter was held or no
//                    coefficients are stored; a thermal run's points alone carry no verdict
//   1  error         no such run, no results stored (an interrupted run says where it
//                    stopped), an unreadable store; 2: usage (as every command)
// FAIL wins over undetermined, which wins over PASS. `results --serial` exits 0 (a listing).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "calib/indirect/indirect_calibration.h"
#include "calib/truth_comparison.h"
#include "io/truth_file.h"
#include "io/verdict.h"
#include "nav/rotation.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {
namespace {

using nlohmann::json;

struct ResultsOptions {
  std::optional<std::string> run;
  std::optional<std::string> serial;
  std::optional<std::string> bench;  // the lab database: one bench's results
  std::string db;
  bool json = false;
  std::string truth;
  std::string coefficients;
};

// One run's results by kind (the newest of each kind).
// Per temperature point of a thermal run (daemon/thermal_points.h pointJson).
constexpr const char* kPointKind = "point_coefficients";

std::map<std::string, json> byKind(const std::vector<StoredResultRow>& rows) {
  std::map<std::string, json> out;
  for (const StoredResultRow& r : rows) out[r.kind] = json::parse(r.json, nullptr, false);
  return out;
}

constexpr int kExitFail = 4;
constexpr int kExitUndetermined = 5;

// The verdict of `results RUN`, worst first.
enum class Outcome { kPass = 0, kUndetermined = 1, kFail = 2 };

Outcome worse(Outcome a, Outcome b) {
  return static_cast<int>(a) >= static_cast<int>(b) ? a : b;
}

// The stored acceptance verdict (daemon/run_calibration.h acceptanceVerdict): a row outside
// its limit fails; rows not determined (or a failed calibration, or no limits) leave it open.
Outcome verdictOutcome(const json& verdict) {
  const json pass = verdict.value("pass", json());
  if (!pass.is_boolean()) return Outcome::kUndetermined;
  if (pass.get<bool>()) return Outcome::kPass;
  const json rows = verdict.contains("rows") ? verdict["rows"] : json::array();
  for (const json& row : rows)
    if (row.is_object() && row.contains("value") && !row.value("pass", true)) return Outcome::kFail;
  return Outcome::kUndetermined;
}

std::string verdictText(const json& verdict) {
  const json pass = verdict.value("pass", json());
  if (!pass.is_boolean()) return "no verdict (" + verdict.value("why", std::string("-")) + ")";
  return pass.get<bool>() ? "PASS" : "FAIL";
}

void printVerdict(const json& verdict) {
  std::cout << "verdict: " << verdictText(verdict) << "\n";
  if (verdict.value("pass", json()).is_boolean() && verdict.contains("why")) {
    std::cout << "  why: " << verdict.value("why", std::string()) << "\n";
  }
  for (const json& f : verdict.value("findings", json::array())) {
    if (f.is_string()) std::cout << "  finding: " << f.get<std::string>() << "\n";
  }
  const json rows = verdict.contains("rows") ? verdict["rows"] : json(json::value_t::array);
  for (const json& row : rows) {
    char buf[200];
    const std::string unit = row.value("unit", "");
    if (row.contains("value")) {
      std::snprintf(buf, sizeof buf, "  %-28s %12.3f %-7s limit %10.3f  %s\n",
                    row.value("parameter", "?").c_str(), row["value"].get<double>(), unit.c_str(),
                    row.value("limit", 0.0), row.value("pass", false) ? "pass" : "FAIL");
    } else {
      std::snprintf(buf, sizeof buf, "  %-28s %12s %-7s limit %10.3f  FAIL: %s\n",
                    row.value("parameter", "?").c_str(), "-", unit.c_str(), row.value("limit", 0.0),
                    row.value("why", "").c_str());
    }
    std::cout << buf;
  }
  if (verdict.contains("notes") && verdict["notes"].is_array()) {
    for (const json& n : verdict["notes"]) {
      if (n.is_string()) std::cout << "  note: " << n.get<std::string>() << "\n";
    }
  }
}

// A stored parameter value of an explain report (scalar, vector or matrix; null when not
// finite) in a few significant digits.
std::string compact(const json& v) {
  if (v.is_number()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v.get<double>());
    return buf;
  }
  if (!v.is_array()) return v.is_null() ? "-" : v.dump();
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + compact(v[i]);
  return out + "]";
}

// The stored missing-physics analysis (imubench-explain/1, interchange.md "Explain report"),
// read as stored: one line per accepted effect with its parameters and sigmas, the residual
// RMS per channel before and after against what the noise floor alone gives, the windows
// nothing in the library explains.
void printExplain(const json& e) {
  if (e.value("format", std::string()) != "imubench-explain/1") {
    std::cout << "missing physics: stored report is not imubench-explain/1\n";
    return;
  }
  const json base = e.value("baseline", json::object());
  std::printf(
      "missing physics (%s baseline): normalised residual RMS %.3g -> %.3g "
      "(1 = noise floor)\n",
      base.value("method", std::string("?")).c_str(), base.value("normalised_rms", 0.0),
      e.value("normalised_rms_after", 0.0));
  const json accepted = e.value("accepted", json::array());
  if (accepted.empty()) std::cout << "  no effect accepted\n";
  for (const json& a : accepted) {
    std::string line = "  accepted " + a.value("effect", std::string("?")) + ":";
    const json none = json::object();
    const json& sigma = a.contains("sigma") ? a["sigma"] : none;
    const json& parameters = a.contains("parameters") ? a["parameters"] : none;
    for (const auto& [name, v] : parameters.items()) {
      line += " " + name + " = " + compact(v);
      if (sigma.contains(name)) line += " +/- " + compact(sigma[name]);
    }
    std::printf("%s (delta BIC %.1f)\n", line.c_str(), a.value("delta_bic", 0.0));
  }
  const json before = e.value("rms_before", json::object());
  const json after = e.value("rms_after", json::object());
  const json noise = e.value("noise_rms", json::object());
  for (const char* triad : {"accel", "gyro"}) {
    const char* unit = std::string(triad) == "accel" ? "m/s^2" : "rad/s";
    for (std::size_t i = 0; i < 3; ++i) {
      auto at = [&](const json& j) {
        return j.contains(triad) && j[triad].size() > i && j[triad][i].is_number()
                   ? j[triad][i].get<double>()
                   : std::nan("");
      };
      std::printf("  %s.%c rms before %10.3e  after %10.3e  noise floor %10.3e %s\n", triad,
                  static_cast<char>('x' + i), at(before), at(after), at(noise), unit);
    }
  }
  std::printf("  unexplained windows: %zu\n", e.value("unexplained", json::array()).size());
}

std::string effectsText(const json& effects) {
  std::string ids;
  for (const json& e : effects) ids += (ids.empty() ? "" : " + ") + e.get<std::string>();
  return ids;
}

// A number of a stored follow-up (null: held or not seen) as text.
std::string sigmaText(const json& v) {
  if (!v.is_number()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v.get<double>());
  return buf;
}

// The follow-up explain proposed at this run's end (daemon/follow_up.h "follow_up").
void printFollowUp(long long run, const json& f) {
  std::cout << "follow-up (policy " << f.value("policy", std::string("?")) << "): ";
  if (f.value("status", std::string()) != "proposed") {
    std::cout << "no plan: " << f.value("reason", std::string("?")) << "\n";
  } else {
    const json& plan = f["plan"];
    std::printf("plan '%s' (%.0f s, %zu blocks) within %.3g deg/s, %.3g deg/s^2; ",
                plan.value("name", std::string()).c_str(), plan.value("duration_s", 0.0),
                plan.value("blocks", json::array()).size(),
                f["limits"].value("max_rate_deg_s", 0.0),
                f["limits"].value("max_accel_deg_s2", 0.0));
    if (f.value("policy", std::string()) == "queue") {
      std::printf("queued when it was stored\n");
    } else {
      std::printf("queue it: imubench queue accept %lld\n", run);
    }
  }
  for (const json& g : f.value("groups", json::array())) {
    std::printf("  %s (%s): %s\n", effectsText(g["effects"]).c_str(),
                g.value("unseparable", false) ? "unseparable" : "short of the precision",
                g.value("resolved", false) ? "separated by the plan"
                                           : ("no plan: " + g.value("why", std::string())).c_str());
    if (g.value("unseparable", false)) {
      std::printf("    principal angle %.3g -> %.3g deg (limit %.3g deg)\n",
                  g.value("angle_before_deg", 0.0), g.value("angle_after_deg", 0.0),
                  g.value("limit_deg", 0.0));
    }
    for (const json& p : g.value("parameters", json::array())) {
      std::printf("    %-36s predicted sigma %s -> %s (with this run: %s) (SI)\n",
                  p.value("name", std::string()).c_str(), sigmaText(p["sigma_before"]).c_str(),
                  sigmaText(p["sigma_after"]).c_str(), sigmaText(p["sigma_joint"]).c_str());
    }
  }
}

// The joint analysis of a follow-up run with its origin (daemon/follow_up.h
// "follow_up_joint"): each group the origin could not separate resolved or not.
void printFollowUpJoint(const json& j) {
  std::cout << "follow-up of run " << j.value("origin_run", json()).dump()
            << ": joint explain over both runs";
  if (!j.value("ok", false)) {
    std::cout << " FAILED: " << j.value("error", std::string("?")) << "\n";
    return;
  }
  std::cout << "\n";
  for (const json& g : j.value("groups", json::array())) {
    const std::string verdict = g.value("verdict", std::string("?"));
    std::printf("  %s: %s\n", effectsText(g["effects"]).c_str(),
                verdict == "resolved" ? "resolved" : "STILL UNSEPARABLE");
    for (const json& p : g.value("parameters", json::array())) {
      std::printf("    %-36s %s  sigma %s (predicted %s) (SI)\n",
                  p.value("name", std::string()).c_str(), sigmaText(p["value"]).c_str(),
                  sigmaText(p["sigma"]).c_str(), sigmaText(p["sigma_predicted"]).c_str());
    }
    for (const json& e : g.value("not_warranted", json::array()))
      std::printf("    %s: not warranted by both runs\n", e.get<std::string>().c_str());
  }
}

void printEstimate(const json& estimate) {
  const json params =
      estimate.contains("parameters") ? estimate["parameters"] : json(json::value_t::object);
  for (const auto& [name, p] : params.items()) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "  %-28s %14.3f %-7s sigma %.3f\n", name.c_str(),
                  p.value("value", 0.0), p.value("unit", "").c_str(), p.value("sigma", 0.0));
    std::cout << buf;
  }
  const json un =
      estimate.contains("unobservable") ? estimate["unobservable"] : json(json::value_t::array);
  if (!un.empty()) {
    std::cout << "  not observable by the plan (held):";
    for (const json& n : un) std::cout << " " << n.get<std::string>();
    std::cout << "\n";
  }
}

// The truth in the frame the method's coefficients refer to (calib/truth_comparison.h).
// The table's geometry comes from the stored report (the run's bench).
calib::BenchTruth expectedTruth(const calib::BenchTruth& truth, const json& report,
                                const calib::CoefficientReport& coefficients) {
  if (report.value("method", std::string()) == "direct") return truth;
  calib::TableGeometry g;
  g.kind = coefficients.values.table_kind;
  g.outer_axis_heading_rad = report.value("outer_axis_heading_deg", 90.0) * kDegToRad;
  return gyroReferencedTruth(truth, g);
}

// --truth: per parameter against the targets: FAIL when one is outside, undetermined when
// one was held (not determined by this calibration).
Outcome compareTruth(const ResultsOptions& o, const json& coefficients, const json& report) {
  const std::string method = report.value("method", std::string());
  calib::CoefficientReport report_coefficients;
  std::string why;
  if (!calib::fromJson(coefficients, &report_coefficients, &why))
    throw CommandFailed("stored coefficients: " + why);
  const calib::TruthComparison c = calib::compareWithTruth(
      report_coefficients, expectedTruth(loadTruthOrFail(o.truth), report, report_coefficients));
  std::printf("comparison with %s (%s; targets: 3 arcsec, 10 ppm, biases 2 sigma)\n",
              o.truth.c_str(),
              method == "direct" ? "truth as written"
                                 : "truth mapped into the gyro-referenced platform frame");
  printComparisonRows(c);
  std::printf("  %d of %d judged parameters within target\n", c.judged - c.outside, c.judged);
  const auto held = std::count_if(c.rows.begin(), c.rows.end(),
                                  [](const calib::ComparisonRow& r) { return !r.observable; });
  if (held > 0) std::printf("  %d parameter(s) not determined (held)\n", static_cast<int>(held));
  if (c.outside > 0) return Outcome::kFail;
  return held > 0 || c.judged == 0 ? Outcome::kUndetermined : Outcome::kPass;
}

// A thermal run's per-point results (kind "point_coefficients", daemon/thermal_points.h),
// one line each: its temperature, the point and whether it calibrated.
void printPoint(long long run, const StoredResultRow& r) {
  const json p = json::parse(r.json, nullptr, false);
  const std::string what = p.is_object() ? p.value("point", std::string("?")) : std::string("?");
  const bool ok = p.is_object() && p.value("ok", false);
  std::printf("%6lld  %10.1f  %-9s  point %s: %s\n", run, r.temperature_c, "direct", what.c_str(),
              ok ? "calibrated"
                 : ("FAILED: " + (p.is_object() ? p.value("error", std::string()) : "")).c_str());
}

// Why a run has no results: an interrupted (or still running, aborted, faulted) run says so
// and where it stopped. Throws CommandFailed (exit 1).
[[noreturn]] void noResults(const ResultsOptions& o, std::int64_t run) {
  const std::string id = std::to_string(run);
  const StoredRunState st = loadRunState(o.db, run);
  std::string m =
      "run " + id + " (plan " + (st.plan_name.empty() ? "?" : st.plan_name) + ") is " + st.state;
  if (st.step) {
    m += st.state == "running" ? ", in step " : ", stopped in step ";
    m += std::to_string(*st.step + 1) + (st.step_label.empty() ? "" : " (" + st.step_label + ")");
    m += st.last_finished_step >= 0
             ? " after step " + std::to_string(st.last_finished_step + 1) + " finished"
             : ", no step finished";
  }
  if (!st.exit_reason.empty()) m += ": " + st.exit_reason;
  if (st.state == "interrupted" || st.state == "aborted" || st.state == "faulted")
    m += "; `imubench resume " + id + "` goes on from its last finished step";
  throw CommandFailed(m + "; no results stored");
}

// A thermal run's per-point results, printed here. true when that was all there is to print
// (only_points: the run has no whole-run results).
bool printPoints(const ResultsOptions& o, std::int64_t run,
                 const std::vector<StoredResultRow>& point_rows, bool only_points) {
  if (point_rows.empty() || (!only_points && o.json)) return false;
  if (o.json) {
    json list = json::array();
    for (const StoredResultRow& r : point_rows) list.push_back(json::parse(r.json, nullptr, false));
    std::cout << json({{"run", run}, {"results", {{kPointKind, list}}}}).dump(2) << "\n";
    return true;
  }
  std::printf("%6s  %10s  %-9s  %s\n", "run", "temp degC", "method", "point");
  for (const StoredResultRow& r : point_rows) printPoint(static_cast<long long>(run), r);
  return only_points;
}

// The human report of one run's results (not its points); returns the verdict.
Outcome printRun(const ResultsOptions& o, std::int64_t run, const StoredResultRow& last,
                 std::map<std::string, json>& k) {
  if (k.count("follow_up_joint") && !k.count("report")) {  // a follow-up run: no calibration
    std::printf("run %lld: IMU %s, follow-up run (no calibration of its own)\n",
                static_cast<long long>(run), last.imu_serial.c_str());
    printFollowUpJoint(k["follow_up_joint"]);
    return Outcome::kUndetermined;
  }
  const json report = k.count("report") ? k["report"] : json::object();
  const std::string method = report.value("method", std::string("?"));
  std::printf("run %lld: IMU %s at %.1f degC, %s calibration%s\n", static_cast<long long>(run),
              last.imu_serial.c_str(), last.temperature_c, method.c_str(),
              report.value("ok", false) ? "" : " FAILED");
  if (report.contains("error")) std::cout << "  " << report["error"].get<std::string>() << "\n";
  if (report.contains("estimate")) printEstimate(report["estimate"]);
  if (k.count("verdict")) printVerdict(k["verdict"]);
  if (k.count("explain")) printExplain(k["explain"]);
  if (k.count("follow_up")) printFollowUp(static_cast<long long>(run), k["follow_up"]);
  if (k.count("follow_up_joint")) printFollowUpJoint(k["follow_up_joint"]);
  if (!o.coefficients.empty()) std::cout << "coefficients written to " << o.coefficients << "\n";
  Outcome out = k.count("verdict") ? verdictOutcome(k["verdict"]) : Outcome::kUndetermined;
  if (!o.truth.empty()) {
    if (k.count("coefficients")) {
      out = worse(out, compareTruth(o, k["coefficients"], report));
    } else {
      std::cout << "--truth: no coefficients stored: nothing to compare (undetermined)\n";
      out = worse(out, Outcome::kUndetermined);
    }
  }
  return out;
}

Outcome runOne(const ResultsOptions& o, std::int64_t run) {
  std::vector<StoredResultRow> rows = loadStoredResults(o.db, run, std::nullopt, o.bench);
  if (rows.empty()) noResults(o, run);
  std::vector<StoredResultRow> point_rows;
  std::erase_if(rows, [&](const StoredResultRow& r) {
    if (r.kind != kPointKind) return false;
    point_rows.push_back(r);
    return true;
  });
  // A thermal run: its temperature points (and its whole-run results, if any, below).
  if (printPoints(o, run, point_rows, rows.empty())) return Outcome::kUndetermined;
  std::map<std::string, json> k = byKind(rows);
  if (!o.coefficients.empty()) {
    if (!k.count("coefficients"))
      throw CommandFailed("run " + std::to_string(run) + ": no coefficients stored");
    if (auto st = io::writeJsonFile(o.coefficients, k["coefficients"]); !st.ok)
      throw CommandFailed(st.message);
  }
  if (o.json) {
    json all = json::object();
    for (const auto& [kind, j] : k) all[kind] = j;
    std::cout << json({{"run", run}, {"results", all}}).dump(2) << "\n";
    return k.count("verdict") ? verdictOutcome(k["verdict"]) : Outcome::kUndetermined;
  }
  return printRun(o, run, rows.back(), k);
}

// The history of one IMU serial: every run with results, across benches in the lab database
// (each line then names its bench).
void runHistory(const ResultsOptions& o) {
  const std::vector<StoredResultRow> rows =
      loadStoredResults(o.db, std::nullopt, o.serial, o.bench);
  using RunKey = std::pair<std::string, std::int64_t>;  // (bench, run): run ids are per bench
  std::map<RunKey, std::vector<StoredResultRow>> runs, points;
  bool lab = false;
  for (const StoredResultRow& r : rows) {
    (r.kind == kPointKind ? points : runs)[{r.bench, r.run_id}].push_back(r);
    lab = lab || !r.bench.empty();
  }
  if (o.json) {
    json list = json::array();
    auto entry = [lab](const RunKey& key, const StoredResultRow& r, json kinds) {
      json e = {{"run", key.second},
                {"imu_serial", r.imu_serial},
                {"temperature_c", r.temperature_c},
                {"created_unix_s", r.created_unix_s},
                {"results", std::move(kinds)}};
      if (lab) e["bench"] = key.first;
      return e;
    };
    for (const auto& [key, rs] : runs) {
      json kinds = json::object();
      for (const auto& [kind, j] : byKind(rs)) kinds[kind] = j;
      list.push_back(entry(key, rs.back(), kinds));
    }
    for (const auto& [key, rs] : points) {
      for (const StoredResultRow& r : rs)
        list.push_back(entry(key, r, {{kPointKind, json::parse(r.json, nullptr, false)}}));
    }
    std::cout << list.dump(2) << "\n";
    return;
  }
  if (runs.empty() && points.empty()) {
    std::cout << "IMU " << *o.serial << ": no results stored\n";
    return;
  }
  if (lab) std::printf("%-16s  ", "bench");
  std::printf("%6s  %10s  %-9s  %s\n", "run", "temp degC", "method", "verdict");
  for (const auto& [key, rs] : runs) {
    std::map<std::string, json> k = byKind(rs);
    const std::string method =
        k.count("report") ? k["report"].value("method", std::string("-")) : std::string("-");
    if (lab) std::printf("%-16s  ", key.first.c_str());
    std::printf("%6lld  %10.1f  %-9s  %s\n", static_cast<long long>(key.second),
                rs.back().temperature_c, method.c_str(),
                k.count("verdict") ? io::verdictWord(k["verdict"]).c_str() : "(no verdict)");
  }
  for (const auto& [key, rs] : points) {
    for (const StoredResultRow& r : rs) {
      if (lab) std::printf("%-16s  ", key.first.c_str());
      printPoint(static_cast<long long>(key.second), r);
    }
  }
}

void runResults(const ResultsOptions& o) {
  if (o.run.has_value() == o.serial.has_value())
    throw CommandFailed("give either RUN or --serial S", 2);
  if (o.serial) {
    runHistory(o);
    return;
  }
  const std::optional<std::int64_t> id = parseRunId(*o.run);
  if (!id) throw CommandFailed("'" + *o.run + "' is not a run id (N or run:N)", 2);
  const std::string which = "run " + std::to_string(*id) + ": ";
  switch (runOne(o, *id)) {
    case Outcome::kPass:
      return;
    case Outcome::kFail:
      throw CommandFailed(which + "FAIL (exit " + std::to_string(kExitFail) + ")", kExitFail);
    case Outcome::kUndetermined:
      throw CommandFailed(which + "no PASS/FAIL verdict: undetermined (exit " +
                              std::to_string(kExitUndetermined) + ")",
                          kExitUndetermined);
  }
}

}  // namespace

void addResultsCommand(CLI::App& app) {
  auto o = std::make_shared<ResultsOptions>();
  CLI::App* sub = app.add_subcommand(
      "results",
      "a run's stored calibration results (verdict, coefficients, missing physics), or an "
      "IMU's history. Exit codes of RUN: 0 PASS, 4 FAIL, 5 undetermined (no acceptance limits, "
      "calibration failed, a parameter not determined), 1 error (no such run; no results: an "
      "interrupted run says where it stopped), 2 usage");
  sub->add_option("RUN", o->run, "run id (N or run:N)");
  sub->add_option("--serial", o->serial,
                  "list the results of this IMU serial (with --db postgresql://...: on every "
                  "bench of the lab database)");
  sub->add_option("--bench", o->bench,
                  "the lab database (--db postgresql://...): only this bench's results (a run "
                  "id names a run together with its bench)");
  sub->add_flag("--json", o->json, "print the stored results as JSON");
  sub->add_option("--truth", o->truth,
                  "RUN: compare the stored coefficients with this truth file (3 arcsec, 10 ppm, "
                  "biases 2 sigma); one outside: FAIL (exit 4), one held: undetermined (exit 5)");
  sub->add_option("--coefficients", o->coefficients,
                  "RUN: write the stored coefficient file (interchange JSON) here");
  addStoreOption(*sub, &o->db);
  sub->callback([o] { runResults(*o); });
}

}  // namespace imubench::tools
