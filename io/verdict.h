// The acceptance verdict's short word, read from the JSON the daemon stores with a run's
// results (daemon/run_calibration.h acceptanceVerdict) or broadcasts in its "results" event:
// both carry "pass" (true, false, or null for no verdict) and "usable" (false when the fit is
// unusable). One judgement for the history (`imubench results --serial`), `imubench watch` and
// the daemon's log.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

namespace imubench::io {

// "PASS", "FAIL", "no verdict (fit unusable)" (pass null, usable false) or "no verdict".
std::string verdictWord(const nlohmann::json& verdict);

}  // namespace imubench::io
