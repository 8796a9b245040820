// Honest output (issue 26, item 4): a baseline the motion cannot determine is refused before
// any analysis; "within the noise floor" only when every channel is; noise-free data said as
// such, with no normalised figures; the motion and time-axis checks of calib/recording_checks.h.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "calib/recording_checks.h"
#include "explain_sim.h"
#include "test_indirect_motions.h"

namespace imubench::calib::testing {
namespace {

RecordingView viewOf(const SimulatedRecording& rec) {
  return {rec.geometry, rec.site, rec.sim.imu, rec.sim.table, rec.sim.segments};
}

// The table never moves: holds at one orientation for 10 minutes.
Motion oneOrientation() {
  MotionBuilder b(TableKind::kTwoAxis);
  for (int k = 0; k < 10; ++k) b.hold(60.0, "h" + std::to_string(k));
  return b.finish();
}

TEST(ExplainHonest, MotionSupportOfTheDirectPlanDeterminesBothTriads) {
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  const MotionSupport m = motionSupport(viewOf(rec));
  std::cout << m.describe() << "\n";
  EXPECT_TRUE(m.determinesTriads()) << m.missing();
  EXPECT_GE(m.attitudes.size(), 6u);
  EXPECT_GE(m.rotation_axes, 3);
  EXPECT_EQ(m.source, "table angles");
}

TEST(ExplainHonest, OneOrientationHasOneAttitudeAndNoRotation) {
  const SimulatedRecording rec = simulateWith(oneOrientation(), EffectSet{}, 5);
  const MotionSupport m = motionSupport(viewOf(rec));
  EXPECT_EQ(m.attitudes.size(), 1u);
  EXPECT_EQ(m.rotation_axes, 0);
  EXPECT_FALSE(m.determinesTriads());
  EXPECT_NE(m.missing().find("gyro scale of axis x, y, z"), std::string::npos) << m.missing();
}

// The case: a baseline calibrated from a one-orientation recording (the indirect
// method ran and returned numbers) is refused before any analysis, as unusable.
TEST(ExplainHonest, OneOrientationBaselineIsRefusedBeforeAnalysis) {
  const SimulatedRecording rec = simulateWith(oneOrientation(), EffectSet{}, 5);
  ExplainInput in;
  in.recording() = viewOf(rec);
  in.baseline.values.sensors = exampleSensors();
  in.baseline_method = "indirect";
  const ExplainResult r = explainRecording(in);
  ASSERT_FALSE(r.status.ok) << summary(r);
  EXPECT_TRUE(r.unusable);
  EXPECT_NE(r.status.message.find("cannot determine"), std::string::npos) << r.status.message;
  EXPECT_NE(r.status.message.find("1 distinct attitude"), std::string::npos) << r.status.message;
}

// Vibration during motion: extra white noise on gyro x outside the static holds, which the
// noise floor (measured on the holds) does not see. No single window stands out at 5 sigma, but
// the channel is well above the floor: the verdict must not say "within the noise floor".
TEST(ExplainHonest, ChannelAboveTheFloorIsNotWithinTheNoiseFloor) {
  SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  GaussianSource g(99);
  const double arw = 0.002 * kDegToRad / 60.0;  // nav-grade ARW, rad/sqrt(s)
  for (std::size_t i = 1; i < rec.sim.imu.size(); ++i) {
    nav::ImuSample& s = rec.sim.imu[i];
    const bool in_hold =
        std::any_of(rec.sim.segments.begin(), rec.sim.segments.end(), [&](const Segment& seg) {
          return seg.kind == SegmentKind::kStatic && s.t >= seg.t0 && s.t <= seg.t1;
        });
    if (!in_hold) s.dtheta.x() += 3.5 * arw * std::sqrt(s.t - rec.sim.imu[i - 1].t) * g.next();
  }
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  std::cout << summary(r) << "gyro.x normalised " << r.channel_normalised_rms[3] << " limit "
            << r.channel_limit[3] << "\n";
  ASSERT_TRUE(r.unexplained.empty()) << "a window stands out: not the case under test";
  const std::vector<int> above = channelsAboveFloor(r);
  EXPECT_NE(std::find(above.begin(), above.end(), 3), above.end());
  const std::string v = explainVerdict(r);
  EXPECT_EQ(v.find("within the noise floor"), std::string::npos) << v;
  EXPECT_NE(v.find("gyro.x"), std::string::npos) << v;
  EXPECT_EQ(toJson(r)["channels_above_floor"][0], "gyro.x");
}

TEST(ExplainHonest, CleanRecordingIsWithinTheNoiseFloorOnEveryChannel) {
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(channelsAboveFloor(r).empty()) << summary(r);
  EXPECT_NE(explainVerdict(r).find("within the noise floor"), std::string::npos);
}

// Noise-free data: the static readings take one value, the floor is the clamp: said, and no
// normalised figure in the JSON.
TEST(ExplainHonest, NoiseFreeDataIsSaid) {
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4,
                                              50.0, 20.0, NoiseModel::none());
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(r.noise.anyResolutionLimited());
  const std::string v = explainVerdict(r);
  EXPECT_NE(v.find("show no noise"), std::string::npos) << v;
  EXPECT_EQ(v.find("within the noise floor"), std::string::npos) << v;
  const nlohmann::json j = toJson(r);
  EXPECT_TRUE(j["normalised_rms_after"].is_null());
  EXPECT_TRUE(j["baseline"]["normalised_rms"].is_null());
  EXPECT_TRUE(j["noise_floor"]["resolution_limited"]["accel"][0].get<bool>());
  ASSERT_FALSE(r.notes.empty());
  EXPECT_NE(r.notes.front().find("show no noise"), std::string::npos);
}

TEST(ExplainHonest, NoisyRecordingIsNotResolutionLimited) {
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  const ExplainResult r = explainSimulated(rec);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_FALSE(r.noise.anyResolutionLimited());
  for (int n : r.noise.distinct_values) EXPECT_GT(n, 100);
}

// The gyro's integrated rotation against the table's: consistent on the recording, a factor 2
// off when the increments are read at the wrong scale (a wrong unit or time axis).
TEST(ExplainHonest, RateConsistencyOfATableRecording) {
  SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), EffectSet{}, 4);
  const RateConsistency ok = checkRateConsistency(viewOf(rec));
  EXPECT_TRUE(ok.judged);
  EXPECT_TRUE(ok.status.ok) << ok.status.message;
  EXPECT_NEAR(ok.factor, 1.0, 0.01);
  for (nav::ImuSample& s : rec.sim.imu) s.dtheta *= 2.0;
  const RateConsistency bad = checkRateConsistency(viewOf(rec));
  ASSERT_FALSE(bad.status.ok);
  EXPECT_NEAR(bad.factor, 2.0, 0.02);
  EXPECT_NE(bad.status.message.find("time stamps or gyro unit"), std::string::npos);
}

}  // namespace
}  // namespace imubench::calib::testing
