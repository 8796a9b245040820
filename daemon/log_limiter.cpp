#include "daemon/log_limiter.h"

#include <algorithm>
#include <cmath>

namespace imubench::daemon {
namespace {

std::string seconds(double s) {
  return std::to_string(std::lround(s)) + " s";
}

}  // namespace

bool LogLimiterOptions::IsValid(std::string* why) const {
  if (!(summary_period_s > 0.0)) {
    if (why != nullptr) *why = "summary_period_s must be positive";
    return false;
  }
  return true;
}

LogLimiter::LogLimiter(Output out, LogLimiterOptions options)
    : out_(std::move(out)), options_(options) {}

void LogLimiter::report(const std::string& topic, LogLevel level, const std::string& message,
                        double now_s) {
  auto it = episodes_.find(topic);
  if (it == episodes_.end()) {
    Episode e;
    e.started_s = e.window_s = e.last_s = now_s;
    e.total = 1;
    e.latest = message;
    episodes_.emplace(topic, std::move(e));
    out_(level, message);
    return;
  }
  Episode& e = it->second;
  e.last_s = now_s;
  ++e.total;
  ++e.pending;
  e.latest = message;
  e.level = std::max(e.level, level);
  if (now_s - e.window_s >= options_.summary_period_s) summarise(topic, e, now_s);
}

void LogLimiter::summarise(const std::string& topic, Episode& e, double now_s) {
  if (e.pending > 0) {
    out_(e.level, topic + ": " + std::to_string(e.pending) + " more like this in the last " +
                      seconds(now_s - e.window_s) + "; latest: " + e.latest);
  }
  e.pending = 0;
  e.level = LogLevel::kDebug;
  e.window_s = now_s;
}

void LogLimiter::tick(double now_s) {
  for (auto it = episodes_.begin(); it != episodes_.end();) {
    Episode& e = it->second;
    if (e.pending > 0 && now_s - e.window_s >= options_.summary_period_s) {
      summarise(it->first, e, now_s);
    }
    if (now_s - e.last_s < options_.summary_period_s) {
      ++it;
      continue;
    }
    if (e.total > 1) {
      summarise(it->first, e, now_s);
      out_(LogLevel::kNotice, it->first + ": no more messages for " + seconds(now_s - e.last_s) +
                                  " (" + std::to_string(e.total) + " in " +
                                  seconds(e.last_s - e.started_s) + ")");
    }
    it = episodes_.erase(it);
  }
}

}  // namespace imubench::daemon
