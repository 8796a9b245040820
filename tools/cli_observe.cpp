// imubench plan observe PLAN [--method direct|indirect] [--latitude DEG] [--json]:
// expands the plan to its table motion, linearises the chosen method's measurement model
// around the nominal bench and prints the information analysis: eigenvalues, the null
// directions in named parameters and plain-language statements of what the plan can and
// cannot estimate. Registers under the existing "plan" subcommand (call after
// addPlanCommand).
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "calib/observability.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"
#include "tools/cli_common.h"

namespace imubench::tools {

void addObserveCommand(CLI::App& app);

namespace {

struct ObserveOptions {
  std::string path;
  std::string method = "indirect";
  double latitude_deg = 55.75;
  bool json = false;
};

void runObserve(const ObserveOptions& o) {
  io::Diagnostics diag(o.path);
  auto plan = plans::loadPlanFile(o.path, diag);
  if (!plan || !plans::validatePlan(*plan, diag)) {
    std::cerr << diag.str();
    throw CommandFailed(o.path + ": plan refused");
  }
  const plans::ExpandResult ex = plans::expand(*plan);
  if (!ex.status.ok) throw CommandFailed(o.path + ": " + ex.status.message);
  calib::PlanObservabilityOptions opt;
  opt.site.latitude_rad = o.latitude_deg * kDegToRad;
  const calib::CalibrationMethod m = o.method == "direct" ? calib::CalibrationMethod::kDirect
                                                          : calib::CalibrationMethod::kIndirect;
  const calib::PlanObservability r = calib::analysePlanObservability(ex.motion, m, opt);
  if (!r.analysis.status.ok) throw CommandFailed(o.path + ": " + r.analysis.status.message);
  const calib::InformationAnalysis& a = r.analysis;
  if (o.json) {
    nlohmann::json j;
    j["plan"] = o.path;
    j["method"] = o.method;
    j["parameters"] = a.names;
    j["eigenvalues"] =
        std::vector<double>(a.eigenvalues.data(), a.eigenvalues.data() + a.eigenvalues.size());
    for (std::size_t k = 0; k < a.names.size(); ++k) j["observable"][a.names[k]] = a.observable[k];
    for (const auto& d : a.null_directions)
      j["null_directions"].push_back({{"eigenvalue", d.eigenvalue}, {"direction", d.description}});
    for (std::size_t k = 0; k < r.model_analysis.names.size(); ++k) {
      j["model_observable"][r.model_analysis.names[k]] = r.model_analysis.observable[k];
    }
    j["statements"] = r.statements;
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << "plan " << o.path << ", method " << o.method << ", " << a.names.size()
            << " parameters, condition (observable part) " << std::setprecision(3) << a.condition
            << "\n\nnull directions (eigenvalue of the column-normalised information matrix):\n";
  for (const auto& d : a.null_directions)
    std::cout << "  " << std::setprecision(2) << d.eigenvalue << "  " << d.description << "\n";
  std::cout << "\nunobservable parameters (fixed, \"observable\": false):\n";
  for (std::size_t k = 0; k < a.names.size(); ++k)
    if (!a.observable[k]) std::cout << "  " << a.names[k] << "\n";
  std::cout << "\nstatements:\n";
  for (const std::string& s : r.statements) std::cout << "  " << s << "\n";
}

}  // namespace

void addObserveCommand(CLI::App& app) {
  CLI::App* plan = app.get_subcommand("plan");  // created by addPlanCommand
  auto opt = std::make_shared<ObserveOptions>();
  CLI::App* sub = plan->add_subcommand(
      "observe", "information matrix of a plan: what the chosen method can estimate");
  sub->add_option("plan", opt->path, "plan file (TOML)")->required();
  sub->add_option("--method", opt->method, "calibration method")
      ->check(CLI::IsMember({"direct", "indirect"}));
  sub->add_option("--latitude", opt->latitude_deg, "site latitude, deg");
  sub->add_flag("--json", opt->json, "machine-readable output");
  sub->callback([opt] { runObserve(*opt); });
}

}  // namespace imubench::tools
