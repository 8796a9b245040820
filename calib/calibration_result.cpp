#include "calib/calibration_result.h"

#include <cstdio>

namespace imubench::calib {

std::string WeakDirection::describe() const {
  std::string s;
  char buf[96];
  for (const auto& [name, value] : components) {
    std::snprintf(buf, sizeof(buf), "%s%.2f %s", s.empty() ? "" : " ", value, name.c_str());
    s += buf;
  }
  std::snprintf(buf, sizeof(buf), "  (sigma %.3g x typical, relative eigenvalue %.3g)",
                sigma_typical, relative_eigenvalue);
  return s + buf;
}

std::string Conditioning::describe() const {
  std::string s;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "condition number %.3g%s\n", condition_number,
                bad ? " (BAD)" : "");
  s += buf;
  for (const std::string& f : fixed_unobservable) s += "fixed, unobservable: " + f + "\n";
  for (const WeakDirection& w : weak) s += "weak direction: " + w.describe() + "\n";
  return s;
}

nlohmann::json toJson(const Conditioning& c) {
  nlohmann::json j;
  j["condition_number"] = c.condition_number;
  j["bad"] = c.bad;
  j["fixed_unobservable"] = c.fixed_unobservable;
  nlohmann::json weak = nlohmann::json::array();
  for (const WeakDirection& w : c.weak) {
    nlohmann::json comps = nlohmann::json::object();
    for (const auto& [name, value] : w.components) comps[name] = value;
    weak.push_back({{"relative_eigenvalue", w.relative_eigenvalue},
                    {"sigma_typical", w.sigma_typical},
                    {"components", comps}});
  }
  j["weak_directions"] = weak;
  return j;
}

}  // namespace imubench::calib
