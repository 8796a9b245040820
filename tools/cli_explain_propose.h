// `imubench explain RUN_OR_DIR --propose-plan OUT.toml [--bench BENCH.toml] [--max-duration S]
// [--precision F]` (issue 27 item 1): after the analysis, the plan that separates what it could
// not (calib/explain/explain_propose.h), printed per group and written as plan TOML.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "calib/explain/explain.h"

namespace imubench::tools {

struct ProposeCliOptions {
  std::string out;    // --propose-plan: the plan file to write (empty: no proposal)
  std::string bench;  // --bench: the bench file whose [table] limits bound the plan
  std::optional<double> max_duration_s;
  std::optional<double> precision;  // relative precision of accepted effects
};

// Prints the proposal; writes the plan (checked like `imubench plan check`) when there is
// one. Throws CommandFailed on a bad bench file or options (exit 2) and a refused plan (1).
// Returns the proposal in JSON for the --json report's "proposal" (docs/explain.md): "plan"
// (the file written, or null), "duration_s", "groups" (calib::toJson of each), "notes".
nlohmann::json proposeFromExplain(const ProposeCliOptions& options,
                                  const calib::ExplainInput& input,
                                  const calib::ExplainResult& result,
                                  const calib::ExplainOptions& explain_options);

}  // namespace imubench::tools
