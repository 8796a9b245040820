// imubench plan check PLAN: prints every problem (file:line:column: reason) on stderr and
// exits 1, or prints the plan summary.
#include <iostream>
#include <memory>

#include "plans/validator.h"
#include "tools/cli_common.h"

namespace imubench::tools {
namespace {

void runPlanCheck(const std::string& path) {
  const plans::PlanCheck check = plans::checkPlan(path);
  if (!check.status.ok) {
    for (const auto& d : check.diagnostics) std::cerr << d.str() << "\n";
    throw CommandFailed(check.status.message);
  }
  std::cout << plans::formatSummary(check.summary) << "\n" << path << ": OK\n";
}

}  // namespace

void addPlanCommand(CLI::App& app) {
  CLI::App* plan = app.add_subcommand("plan", "plan files");
  plan->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  CLI::App* check = plan->add_subcommand("check", "validate a plan file (exit 1 on errors)");
  check->add_option("plan", *path, "plan file (TOML)")->required();
  check->callback([path] { runPlanCheck(*path); });
}

}  // namespace imubench::tools
