#include "calib/calibration_result.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "calib/option_check.h"

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

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string groupOf(const std::string& name) {
  const std::size_t dot = name.rfind('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

}  // namespace

bool SigmaCheckOptions::IsValid(std::string* why) const {
  if (!(min_ratio > 0.0) || !(max_ratio > min_ratio)) {
    return invalidOption(why, "sigma check: need 0 < min_ratio < max_ratio");
  }
  if (min_resamples < 2) return invalidOption(why, "sigma check: min_resamples must be >= 2");
  return true;
}

SigmaCheck compareSigmas(const std::map<std::string, double>& printed,
                         const std::map<std::string, double>& resampled,
                         const SigmaCheckOptions& o) {
  SigmaCheck c;
  c.min_ratio = o.min_ratio;
  c.max_ratio = o.max_ratio;
  std::map<std::string, std::vector<double>> by_group;
  std::vector<double> all;
  for (const auto& [name, rs] : resampled) {
    const auto it = printed.find(name);
    if (it == printed.end() || !(it->second > 0.0) || !std::isfinite(rs)) continue;
    const double ratio = rs / it->second;
    by_group[groupOf(name)].push_back(ratio);
    all.push_back(ratio);
    c.resampled_sigma[name] = rs;
  }
  if (all.empty()) {
    c.why_not = "no parameter estimated in every resample";
    return c;
  }
  for (const auto& [group, ratios] : by_group) {
    c.groups.push_back({group, median(ratios), static_cast<int>(ratios.size())});
  }
  c.median_ratio = median(all);
  c.outside = c.median_ratio < o.min_ratio || c.median_ratio > o.max_ratio;
  c.done = true;
  return c;
}

void raiseSigmas(CoefficientReport* report, SigmaCheck* check) {
  if (!check->done || !check->outside) return;
  for (const auto& [name, rs] : check->resampled_sigma) {
    Uncertainty& u = report->uncertainty[name];
    if (u.sigma && rs > *u.sigma) {
      u.sigma = rs;
      check->sigmas_raised = true;
    }
  }
}

std::map<std::string, double> jackknifeSigmas(
    const std::vector<std::map<std::string, double>>& estimates) {
  std::map<std::string, double> out;
  if (estimates.size() < 2) return out;
  const double n = static_cast<double>(estimates.size());
  for (const auto& [name, unused] : estimates.front()) {
    double sum = 0.0, sum2 = 0.0;
    bool everywhere = true;
    for (const auto& e : estimates) {
      const auto it = e.find(name);
      if (it == e.end()) {
        everywhere = false;
        break;
      }
      sum += it->second;
    }
    if (!everywhere) continue;
    const double mean = sum / n;
    for (const auto& e : estimates) sum2 += (e.at(name) - mean) * (e.at(name) - mean);
    out[name] = std::sqrt((n - 1.0) / n * sum2);
  }
  return out;
}

std::string SigmaCheck::describe() const {
  if (!done) return "sigma check: not done (" + why_not + ")\n";
  char buf[160];
  std::snprintf(buf, sizeof(buf), "sigma check (%s, %d resamples): resampled / printed sigma %.2f",
                method.c_str(), resamples, median_ratio);
  std::string s = buf;
  for (const SigmaGroupRatio& g : groups) {
    std::snprintf(buf, sizeof(buf), "%s %s %.2f", g.group == groups.front().group ? ";" : ",",
                  g.group.c_str(), g.median);
    s += buf;
  }
  s += "\n";
  if (outside) {
    std::snprintf(buf, sizeof(buf), "  outside [%.2g, %.2g]: ", min_ratio, max_ratio);
    s += buf;
    s += sigmas_raised ? "the printed sigmas are the larger of the fit's and the resampled ones\n"
                       : "the fit's sigmas are larger than the resampled ones and are kept "
                         "(conservative)\n";
  }
  return s;
}

nlohmann::json toJson(const SigmaCheck& c) {
  nlohmann::json j;
  j["done"] = c.done;
  if (!c.done) {
    j["why_not"] = c.why_not;
    return j;
  }
  j["method"] = c.method;
  j["resamples"] = c.resamples;
  j["median_ratio"] = c.median_ratio;
  j["outside"] = c.outside;
  j["sigmas_raised"] = c.sigmas_raised;
  nlohmann::json groups = nlohmann::json::object();
  for (const SigmaGroupRatio& g : c.groups) {
    groups[g.group] = {{"median_ratio", g.median}, {"parameters", g.parameters}};
  }
  j["groups"] = groups;
  return j;
}

}  // namespace imubench::calib
