// Segments checked against the encoders (calib/segment_check.h) and the fit-quality findings
// (calib/fit_quality.h): a hold split into settle + hold is one hold, a static segment in
// which the table moves is named and dropped, a rotate segment without motion is named;
// undetermined and implausible coefficients make a result unusable.
#include <gtest/gtest.h>

#include "calib/fit_quality.h"
#include "calib/segment_check.h"

namespace imubench::calib {
namespace {

// Encoder samples every 10 ms: inner axis at `a0` until t = 10, turning to a0 + 90 deg by
// t = 15, resting there until t = 30.
std::vector<TableSample> table(double a0) {
  std::vector<TableSample> out;
  for (int k = 0; k <= 3000; ++k) {
    const double t = 0.01 * k;
    const double w = std::clamp((t - 10.0) / 5.0, 0.0, 1.0);
    out.push_back({t, {0.0, 0.0, a0 + w * kPi / 2.0}});
  }
  return out;
}

Segment seg(double t0, double t1, SegmentKind kind, const std::string& label) {
  Segment s;
  s.t0 = t0;
  s.t1 = t1;
  s.kind = kind;
  s.label = label;
  return s;
}

TEST(SegmentCheck, SettleAndHoldAtTheSameAnglesAreOneHold) {
  const std::vector<Segment> in = {seg(0.0, 2.0, SegmentKind::kStatic, "settle-1"),
                                   seg(2.0, 10.0, SegmentKind::kStatic, "hold-1"),
                                   seg(10.0, 15.0, SegmentKind::kRotate, "run-1"),
                                   seg(15.0, 17.0, SegmentKind::kStatic, "settle-2"),
                                   seg(17.0, 30.0, SegmentKind::kStatic, "hold-2")};
  const SegmentCheckResult r = checkSegments(TableKind::kTwoAxis, table(0.3), in);
  ASSERT_EQ(r.segments.size(), 3u);
  EXPECT_EQ(r.merged, 2);
  EXPECT_EQ(r.segments[0].label, "settle-1+hold-1");
  EXPECT_DOUBLE_EQ(r.segments[0].t0, 0.0);
  EXPECT_DOUBLE_EQ(r.segments[0].t1, 10.0);
  EXPECT_EQ(r.segments[2].label, "settle-2+hold-2");
  EXPECT_TRUE(r.contradictions.empty());
}

TEST(SegmentCheck, AdjacentStaticsAtDifferentAnglesStayApart) {
  // No rotate segment between the two statics, but the encoders turned: two positions.
  const std::vector<Segment> in = {seg(0.0, 9.0, SegmentKind::kStatic, "a"),
                                   seg(16.0, 30.0, SegmentKind::kStatic, "b")};
  SegmentCheckOptions o;
  o.adjacency_s = 10.0;
  const SegmentCheckResult r = checkSegments(TableKind::kTwoAxis, table(0.0), in, o);
  EXPECT_EQ(r.segments.size(), 2u);
  EXPECT_EQ(r.merged, 0);
}

TEST(SegmentCheck, StaticSegmentWithMotionIsNamedAndDropped) {
  const std::vector<Segment> in = {seg(0.0, 9.0, SegmentKind::kStatic, "a"),
                                   seg(9.5, 16.0, SegmentKind::kStatic, "moving"),
                                   seg(16.0, 30.0, SegmentKind::kStatic, "b")};
  const SegmentCheckResult r = checkSegments(TableKind::kTwoAxis, table(0.0), in);
  ASSERT_EQ(r.contradictions.size(), 1u);
  EXPECT_NE(r.contradictions[0].find("'moving' (9.500-16.000 s)"), std::string::npos);
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_EQ(r.segments[0].label, "a");
  EXPECT_EQ(r.segments[1].label, "b");
}

TEST(SegmentCheck, RotateSegmentWithoutMotionIsNamed) {
  const std::vector<Segment> in = {seg(0.0, 9.0, SegmentKind::kRotate, "still-run")};
  const SegmentCheckResult r = checkSegments(TableKind::kTwoAxis, table(0.0), in);
  ASSERT_EQ(r.contradictions.size(), 1u);
  EXPECT_NE(r.contradictions[0].find("'still-run'"), std::string::npos);
  EXPECT_EQ(r.segments.size(), 1u);  // kept: the calibrators skip it with their own note
}

TEST(SegmentCheck, HoldAtTheEncoderWrapIsOneAngle) {
  // A hold at 180 deg whose readings jitter across the +-180 wrap is still, and the hold
  // after the settle at the same angle joins it.
  std::vector<TableSample> t;
  for (int k = 0; k <= 1000; ++k) {
    t.push_back({0.01 * k, {0.0, 0.0, (k % 2 ? 1.0 : -1.0) * (kPi - 1e-7)}});
  }
  const std::vector<Segment> in = {seg(0.0, 2.0, SegmentKind::kStatic, "settle"),
                                   seg(2.0, 10.0, SegmentKind::kStatic, "hold")};
  const SegmentCheckResult r = checkSegments(TableKind::kTwoAxis, t, in);
  EXPECT_TRUE(r.contradictions.empty());
  EXPECT_EQ(r.segments.size(), 1u);
}

TEST(FitQuality, UndeterminedAndImplausibleCoefficientsMakeAResultUnusable) {
  CoefficientReport rep;
  for (const std::string& n : flatNames(rep.values)) rep.setSigma(n, 1e-6);
  std::vector<std::string> reasons;
  judgeCoefficients(rep, {}, &reasons);
  EXPECT_TRUE(reasons.empty());
  EXPECT_TRUE(fitStatusFrom(reasons, {}).IsSolutionUsable());

  rep.setUnobservable("gyro.scale.x");
  rep.setSigma("gyro.scale.y", 5e-4);         // 500 ppm: not determined
  rep.values.sensors.accel.scale.x() = 1e-4;  // a swapped column
  judgeCoefficients(rep, {}, &reasons);
  ASSERT_EQ(reasons.size(), 3u);
  const FitStatus s = fitStatusFrom(reasons, {"hold 'h' accel: 40 sigma"});
  EXPECT_FALSE(s.IsSolutionUsable());
  EXPECT_EQ(s.code, FitStatusCode::kUnusable);
  EXPECT_NE(s.message.find("result unusable"), std::string::npos);
  EXPECT_EQ(s.largest_residuals.size(), 1u);
}

}  // namespace
}  // namespace imubench::calib
