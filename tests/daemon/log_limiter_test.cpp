// LogLimiter with a fake clock (issue 17, defect 8: a failing table flooded the log).
#include "daemon/log_limiter.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace imubench::daemon {
namespace {

struct Line {
  LogLevel level;
  std::string text;
};

struct Capture {
  std::vector<Line> lines;
  LogLimiter::Output out() {
    return [this](LogLevel level, const std::string& text) { lines.push_back({level, text}); };
  }
};

// A table failing on every 20 ms poll for 60 s (3 messages per poll), the daemon ticking
// once a second: the first message as it is, one summary per 10 s, the end once it stops.
TEST(LogLimiter, SixtySecondsOfFailuresWriteAFewLines) {
  Capture cap;
  LogLimiter limiter(cap.out());
  std::uint64_t sent = 0;
  for (int poll = 0; poll < 3000; ++poll) {
    const double now = 0.02 * poll;
    for (int attempt = 1; attempt <= 3; ++attempt) {
      limiter.report("table", LogLevel::kWarning,
                     "table: read angle: attempt " + std::to_string(attempt) + "/3 failed", now);
      ++sent;
    }
    if (poll % 50 == 0) limiter.tick(now);
  }
  const std::size_t while_failing = cap.lines.size();
  EXPECT_LE(while_failing, 7U);
  // Quiet from 60 s on: the rest is summarised, then the end is logged, once.
  for (int t = 60; t <= 75; ++t) limiter.tick(t);
  ASSERT_GE(cap.lines.size(), 3U);
  EXPECT_EQ(cap.lines[0].level, LogLevel::kWarning);
  EXPECT_EQ(cap.lines[0].text, "table: read angle: attempt 1/3 failed");
  std::uint64_t summarised = 0;
  for (std::size_t k = 1; k + 1 < cap.lines.size(); ++k) {
    const std::string& t = cap.lines[k].text;
    EXPECT_EQ(cap.lines[k].level, LogLevel::kWarning) << t;
    ASSERT_EQ(t.rfind("table: ", 0), 0U) << t;
    EXPECT_NE(t.find(" more like this in the last 10 s; latest: table: read angle: attempt "),
              std::string::npos)
        << t;
    summarised += std::stoull(t.substr(7));
  }
  EXPECT_EQ(summarised + 1, sent);  // every message logged or counted in a summary
  EXPECT_EQ(cap.lines.back().level, LogLevel::kNotice);
  EXPECT_EQ(cap.lines.back().text, "table: no more messages for 10 s (9000 in 60 s)");
  EXPECT_EQ(cap.lines.size(), while_failing + 2);  // the last summary and the end
}

// Topics are independent; a summary carries the worst level it counted; a topic that ended
// logs its next message again at once.
TEST(LogLimiter, TopicsLevelsAndAFreshStart) {
  Capture cap;
  LogLimiter limiter(cap.out(), LogLimiterOptions{.summary_period_s = 5.0});
  limiter.report("table", LogLevel::kWarning, "t1", 0.0);
  limiter.report("chamber", LogLevel::kWarning, "c1", 0.5);
  limiter.report("table", LogLevel::kWarning, "t2", 1.0);
  limiter.report("table", LogLevel::kError, "t3", 2.0);
  limiter.report("table", LogLevel::kWarning, "t4", 5.0);  // the period is over: summary
  ASSERT_EQ(cap.lines.size(), 3U);
  EXPECT_EQ(cap.lines[0].text, "t1");
  EXPECT_EQ(cap.lines[1].text, "c1");
  EXPECT_EQ(cap.lines[2].level, LogLevel::kError);
  EXPECT_EQ(cap.lines[2].text, "table: 3 more like this in the last 5 s; latest: t4");
  limiter.tick(9.0);  // chamber: one message, quiet for 8.5 s: over without a line
  EXPECT_EQ(cap.lines.size(), 3U);
  limiter.report("chamber", LogLevel::kWarning, "c2", 9.5);
  ASSERT_EQ(cap.lines.size(), 4U);
  EXPECT_EQ(cap.lines[3].text, "c2");
  limiter.tick(10.0);  // table: quiet for 5 s after 4 messages
  ASSERT_EQ(cap.lines.size(), 5U);
  EXPECT_EQ(cap.lines[4].text, "table: no more messages for 5 s (4 in 5 s)");
  limiter.report("table", LogLevel::kWarning, "t5", 11.0);
  ASSERT_EQ(cap.lines.size(), 6U);
  EXPECT_EQ(cap.lines[5].text, "t5");
}

TEST(LogLimiter, OptionsChecked) {
  std::string why;
  EXPECT_TRUE(LogLimiterOptions{}.IsValid(&why));
  EXPECT_FALSE(LogLimiterOptions{.summary_period_s = 0.0}.IsValid(&why));
  EXPECT_EQ(why, "summary_period_s must be positive");
}

}  // namespace
}  // namespace imubench::daemon
