// io/verdict.h: the one short verdict word of the history, `watch` and the daemon's log.
#include "io/verdict.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace imubench::io {
namespace {

using nlohmann::json;

TEST(VerdictWord, PassFailAndTheTwoKindsOfNoVerdict) {
  EXPECT_EQ(verdictWord(json{{"pass", true}, {"usable", true}}), "PASS");
  EXPECT_EQ(verdictWord(json{{"pass", false}}), "FAIL");
  // No limits: no verdict; an unusable fit: no verdict, and why in two words.
  EXPECT_EQ(verdictWord(json{{"pass", nullptr}, {"why", "no acceptance limits"}}), "no verdict");
  EXPECT_EQ(verdictWord(json{{"pass", nullptr}, {"usable", false}}), "no verdict (fit unusable)");
  // A stored verdict with a pass is judged by it, whatever "usable" says.
  EXPECT_EQ(verdictWord(json{{"pass", false}, {"usable", false}}), "FAIL");
}

TEST(VerdictWord, MalformedStoredJsonIsNoVerdict) {
  EXPECT_EQ(verdictWord(json()), "no verdict");
  EXPECT_EQ(verdictWord(json::array()), "no verdict");
  EXPECT_EQ(verdictWord(json{{"pass", "yes"}, {"usable", "no"}}), "no verdict");
}

}  // namespace
}  // namespace imubench::io
