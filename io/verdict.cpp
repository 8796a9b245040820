#include "io/verdict.h"

#include <nlohmann/json.hpp>

namespace imubench::io {

std::string verdictWord(const nlohmann::json& verdict) {
  if (!verdict.is_object()) return "no verdict";
  const nlohmann::json pass = verdict.value("pass", nlohmann::json());
  if (pass.is_boolean()) return pass.get<bool>() ? "PASS" : "FAIL";
  const nlohmann::json usable = verdict.value("usable", nlohmann::json(true));
  if (usable.is_boolean() && !usable.get<bool>()) return "no verdict (fit unusable)";
  return "no verdict";
}

}  // namespace imubench::io
