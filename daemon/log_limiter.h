// Rate-limited logging of repeated problems: a device that fails 50 times a second (every
// table poll, each retry) must not flood syslog. Messages are grouped by topic ("table",
// "chamber", "IMU lost samples", ...):
//   - the first message of a topic that was quiet is logged as it is, at its level;
//   - the ones after it are counted, not logged; at most once per summary period the topic
//     logs one summary at the worst level it counted:
//       "<topic>: N more like this in the last T s; latest: <message>";
//   - a topic quiet for a whole period after repeated messages logs its end at notice level,
//       "<topic>: no more messages for T s (N in S s)", and starts afresh.
// Summaries and ends are also logged from tick(), which the owner calls periodically (the
// daemon: its status timer), so a problem that stops is reported without a new message.
// Time is the caller's (monotonic seconds): tests drive it without sleeping.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "daemon/logging.h"

namespace imubench::daemon {

struct LogLimiterOptions {
  // At most one summary line per topic per period, and a problem is over after one quiet
  // period: a device failing for 60 s writes its first message and 6 summaries.
  double summary_period_s = 10.0;
  bool IsValid(std::string* why) const;
};

class LogLimiter {
 public:
  using Output = std::function<void(LogLevel level, const std::string& line)>;
  // options should be valid (the owner checks them); a non-positive period summarises on
  // every repeat.
  explicit LogLimiter(Output out, LogLimiterOptions options = {});

  // A message about topic at level, at the caller's time now_s.
  void report(const std::string& topic, LogLevel level, const std::string& message, double now_s);
  // Logs due summaries and the ends of topics quiet for a whole period.
  void tick(double now_s);

 private:
  struct Episode {
    LogLevel level = LogLevel::kDebug;  // worst level counted since the last line
    double started_s = 0.0;             // first message of the episode
    double window_s = 0.0;              // when the last line about it was logged
    double last_s = 0.0;                // latest message
    std::uint64_t total = 0;            // messages in the episode
    std::uint64_t pending = 0;          // counted since the last line
    std::string latest;
  };
  void summarise(const std::string& topic, Episode& e, double now_s);

  Output out_;
  LogLimiterOptions options_;
  std::map<std::string, Episode> episodes_;
};

}  // namespace imubench::daemon
