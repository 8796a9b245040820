// Pure decode tests (no CAN bus): signal placement, scaling, endianness, signedness, float
// signals, layouts from device files and DBCs, assembly, loss counting, bad frames.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "drivers/can_signal.h"
#include "drivers/dbc_parser.h"
#include "drivers/imu_decoder.h"
#include "drivers/imu_encoder.h"
#include "drivers/virtual_imu_can.h"
#include "tests/can/can_test_util.h"

namespace imubench::drivers {
namespace {

// The samples `dec` decodes from `frames`.
std::vector<DecodedImuSample> decodeAll(ImuDecoder& dec, const std::vector<CanFrame>& frames) {
  std::vector<DecodedImuSample> out;
  dec.feed(frames, &out);
  return out;
}

using testing::expectSameWithinResolution;
using testing::loadShipped;
using testing::makeSamples;

TEST(CanSignal, LittleEndianUnsignedAndSigned) {
  std::uint8_t d[64] = {0x34, 0x12, 0xFE, 0xFF};
  SignalCoding u{.start_bit = 0, .length = 16};
  EXPECT_EQ(extractRaw(u, d), 0x1234U);
  SignalCoding s{.start_bit = 16, .length = 16, .is_signed = true, .factor = 0.5};
  EXPECT_DOUBLE_EQ(decodeSignal(s, d), -1.0);  // 0xFFFE = -2, x 0.5
  SignalCoding nib{.start_bit = 4, .length = 4};
  EXPECT_EQ(extractRaw(nib, d), 0x3U);
}

TEST(CanSignal, BigEndianMotorolaSawtoothNumbering) {
  std::uint8_t d[64] = {0x12, 0x34, 0x56};
  // DBC "7|16@0+": MSB at bit 7 of byte 0, i.e. bytes 0..1 big-endian.
  SignalCoding s{.start_bit = 7, .length = 16, .order = ByteOrder::kBigEndian};
  EXPECT_EQ(extractRaw(s, d), 0x1234U);
  // "3|12@0+": low nibble of byte 0 then byte 1 -> 0x234.
  SignalCoding t{.start_bit = 3, .length = 12, .order = ByteOrder::kBigEndian};
  EXPECT_EQ(extractRaw(t, d), 0x234U);
  EXPECT_EQ(t.bytesNeeded(), 2);
  SignalCoding neg{.start_bit = 15, .length = 8, .order = ByteOrder::kBigEndian, .is_signed = true};
  d[1] = 0x80;
  EXPECT_DOUBLE_EQ(decodeSignal(neg, d), -128.0);
}

TEST(CanSignal, FloatSignals) {
  std::uint8_t d[64] = {};
  const float f = -3.25f;
  std::memcpy(d + 2, &f, 4);
  SignalCoding s{.start_bit = 16, .length = 32, .type = ValueType::kFloat32};
  EXPECT_DOUBLE_EQ(decodeSignal(s, d), -3.25);
  const double g = 1.0e-7;
  std::memcpy(d + 8, &g, 8);
  SignalCoding s64{.start_bit = 64, .length = 64, .type = ValueType::kFloat64};
  EXPECT_DOUBLE_EQ(decodeSignal(s64, d), 1.0e-7);
}

TEST(CanSignal, InsertExtractRoundTripAllPlacements) {
  std::mt19937_64 rng(42);
  for (int order = 0; order < 2; ++order) {
    for (int len = 1; len <= 64; ++len) {
      for (int start = 0; start < 64 * 8; start += 5) {
        SignalCoding s{.start_bit = start,
                       .length = len,
                       .order = order ? ByteOrder::kBigEndian : ByteOrder::kLittleEndian};
        if (s.bytesNeeded() == 0) continue;
        std::uint8_t d[64];
        for (auto& b : d) b = static_cast<std::uint8_t>(rng());
        std::uint8_t before[64];
        std::memcpy(before, d, 64);
        const std::uint64_t mask = len == 64 ? ~0ULL : (1ULL << len) - 1;
        const std::uint64_t v = rng() & mask;
        insertRaw(s, v, d);
        ASSERT_EQ(extractRaw(s, d), v) << "order " << order << " start " << start << " len " << len;
        // Bits outside the signal are untouched: re-inserting the old value restores the buffer.
        insertRaw(s, extractRaw(s, before), d);
        ASSERT_EQ(std::memcmp(d, before, 64), 0) << "start " << start << " len " << len;
      }
    }
  }
}

TEST(CanSignal, EncodeRoundsAndSaturates) {
  SignalCoding s{.start_bit = 0, .length = 16, .is_signed = true, .factor = 0.01};
  std::uint64_t raw = 0;
  EXPECT_TRUE(physicalToRaw(s, 1.234, false, &raw));
  EXPECT_EQ(raw, 123U);
  EXPECT_FALSE(physicalToRaw(s, 1000.0, false, &raw));  // 100000 counts > 32767
  EXPECT_EQ(raw, 32767U);
  EXPECT_FALSE(physicalToRaw(s, -1000.0, false, &raw));
  EXPECT_DOUBLE_EQ(rawToPhysical(s, raw), -327.68);
  SignalCoding c{.start_bit = 0, .length = 8};
  EXPECT_TRUE(physicalToRaw(c, 257.0, true, &raw));  // wraps
  EXPECT_EQ(raw, 1U);
}

TEST(ImuLayoutFile, ShippedLayoutsAreValid) {
  for (const char* name :
       {"sbg_ecan.toml", "sbg_ecan_dbc.toml", "navgrade_fd.toml", "navgrade_fd_dbc.toml"}) {
    ImuLayout l = loadShipped(name);
    std::string why;
    EXPECT_TRUE(l.IsValid(&why)) << name << ": " << why;
  }
  ImuLayout sbg = loadShipped("sbg_ecan.toml");
  ASSERT_EQ(sbg.messages.size(), 3U);
  EXPECT_EQ(sbg.messages[0].id, 0x120U);
  EXPECT_EQ(sbg.messages[1].id, 0x121U);
  EXPECT_EQ(sbg.messages[2].id, 0x122U);
  EXPECT_FALSE(sbg.messages[0].fd);
  ImuLayout nav = loadShipped("navgrade_fd.toml");
  ASSERT_EQ(nav.messages.size(), 1U);
  EXPECT_TRUE(nav.messages[0].fd);
  EXPECT_EQ(nav.messages[0].length, 48);
}

// The DBC reader yields the same frame layout as the byte-level device file.
TEST(ImuLayoutFile, DbcEquivalentToDeviceFile) {
  for (auto [file, dbc] : {std::pair{"sbg_ecan.toml", "sbg_ecan_dbc.toml"},
                           std::pair{"navgrade_fd.toml", "navgrade_fd_dbc.toml"}}) {
    ImuLayout a = loadShipped(file);
    ImuLayout b = loadShipped(dbc);
    ASSERT_EQ(a.messages.size(), b.messages.size()) << file;
    EXPECT_EQ(a.messages[static_cast<std::size_t>(a.start_message)].id,
              b.messages[static_cast<std::size_t>(b.start_message)].id);
    EXPECT_EQ(a.status_ok_mask, b.status_ok_mask);
    for (int qi = 0; qi < kImuQuantityCount; ++qi) {
      const auto q = static_cast<ImuQuantity>(qi);
      int ma = -1;
      int mb = -1;
      const ImuSignal* sa = a.find(q, &ma);
      const ImuSignal* sb = b.find(q, &mb);
      ASSERT_EQ(sa == nullptr, sb == nullptr) << file << " " << imuQuantityName(q);
      if (sa == nullptr) continue;
      EXPECT_EQ(a.messages[static_cast<std::size_t>(ma)].id,
                b.messages[static_cast<std::size_t>(mb)].id);
      EXPECT_EQ(a.messages[static_cast<std::size_t>(ma)].length,
                b.messages[static_cast<std::size_t>(mb)].length);
      EXPECT_EQ(a.messages[static_cast<std::size_t>(ma)].fd,
                b.messages[static_cast<std::size_t>(mb)].fd);
      EXPECT_EQ(sa->coding.start_bit, sb->coding.start_bit) << imuQuantityName(q);
      EXPECT_EQ(sa->coding.length, sb->coding.length) << imuQuantityName(q);
      EXPECT_EQ(sa->coding.order, sb->coding.order) << imuQuantityName(q);
      EXPECT_EQ(sa->coding.is_signed, sb->coding.is_signed) << imuQuantityName(q);
      EXPECT_NEAR(sa->coding.factor, sb->coding.factor, 1e-15 * std::abs(sa->coding.factor));
    }
    // And decodes the same frames to the same samples.
    const auto samples = makeSamples(200, a.sample_period_s);
    ImuEncoder enc(a);
    std::vector<CanFrame> frames;
    for (std::size_t k = 0; k < samples.size(); ++k)
      enc.encode(samples[k], k, enc.goodStatus(), &frames);
    ImuDecoder da(a);
    ImuDecoder db(b);
    std::vector<DecodedImuSample> oa;
    std::vector<DecodedImuSample> ob;
    da.feed(frames, &oa);
    db.feed(frames, &ob);
    ASSERT_EQ(oa.size(), samples.size());
    ASSERT_EQ(ob.size(), samples.size());
    for (std::size_t k = 0; k < oa.size(); ++k) {
      EXPECT_EQ(oa[k].sample.t, ob[k].sample.t);
      EXPECT_EQ(oa[k].sample.dtheta, ob[k].sample.dtheta);
      EXPECT_EQ(oa[k].sample.dvel, ob[k].sample.dvel);
      EXPECT_EQ(oa[k].sample.temp_c, ob[k].sample.temp_c);
    }
  }
}

class RoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(RoundTrip, EncodeDecodeWithinResolutionNoLoss) {
  const ImuLayout layout = loadShipped(GetParam());
  const auto samples = makeSamples(3000, layout.sample_period_s);
  ImuEncoder enc(layout);
  std::vector<CanFrame> frames;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    auto r = enc.encode(samples[k], k, enc.goodStatus(), &frames);
    ASSERT_FALSE(r.saturated);
  }
  EXPECT_EQ(frames.size(), samples.size() * layout.messages.size());
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  expectSameWithinResolution(layout, samples, out);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  EXPECT_EQ(dec.counters().badFrames(), 0U);
  EXPECT_EQ(dec.counters().incomplete, 0U);
  EXPECT_EQ(dec.counters().bad_status, 0U);
}

INSTANTIATE_TEST_SUITE_P(Layouts, RoundTrip,
                         ::testing::Values("sbg_ecan.toml", "sbg_ecan_dbc.toml", "navgrade_fd.toml",
                                           "navgrade_fd_dbc.toml"));

// Resolution claims are honest: the navigation-grade layout resolves 1e-10 rad, SBG 1e-3 rad/s.
TEST(ImuLayoutFile, ResolutionMatchesScaling) {
  ImuLayout nav = loadShipped("navgrade_fd.toml");
  EXPECT_NEAR(nav.resolution(ImuQuantity::kDthetaX), 0.5e-10, 1e-22);
  EXPECT_NEAR(nav.resolution(ImuQuantity::kDvelZ), 0.5e-9, 1e-21);
  ImuLayout sbg = loadShipped("sbg_ecan.toml");
  EXPECT_NEAR(sbg.resolution(ImuQuantity::kDthetaY), 0.5e-3 * 0.01, 1e-15);
  EXPECT_NEAR(sbg.resolution(ImuQuantity::kDvelX), 0.5e-2 * 0.01, 1e-15);
}

std::vector<CanFrame> encodeAll(const ImuLayout& layout, const nav::ImuSamples& samples,
                                const VirtualImuFaults& faults) {
  VirtualImuOptions options;
  options.interface = "unused";
  options.faults = faults;
  VirtualImuCan v(layout, options);
  std::vector<CanFrame> frames;
  v.encodeSamples(samples, &frames);
  return frames;
}

TEST(ImuDecoder, CounterGapsCountLostSamples) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const auto samples = makeSamples(1000, layout.sample_period_s);
  // Every 10th sample's (only) frame dropped: 100 lost.
  const auto frames = encodeAll(layout, samples, {.drop_frame_every = 10});
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  EXPECT_EQ(out.size(), 900U);
  // The last sample (index 999) is dropped and unseen: gaps before 9, 19, ..., 989 = 99.
  EXPECT_EQ(dec.counters().lost_samples, 99U);
  EXPECT_EQ(out[9].sequence, 10U);  // counter of sample 10 follows 8
}

TEST(ImuDecoder, TimeStampGapsCountLostSamplesWithoutCounter) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const auto samples = makeSamples(500, layout.sample_period_s);
  const auto frames = encodeAll(layout, samples, {.drop_frame_every = 50});
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  EXPECT_EQ(out.size(), 490U);
  // 10 samples lost their last frame: each is "incomplete"; 9 gaps are seen (last is at the end).
  EXPECT_EQ(dec.counters().incomplete, 9U);
  EXPECT_EQ(dec.counters().lost_samples, 9U);
}

TEST(ImuDecoder, CounterAndTimeWrapAround) {
  ImuLayout layout = loadShipped("navgrade_fd.toml");
  // Start 3 samples before the 32-bit counter and 2^32 us time stamp wrap.
  const double t0 = 4294.967296 - 3 * layout.sample_period_s;
  const auto samples = makeSamples(10, layout.sample_period_s, 7, t0 - layout.sample_period_s);
  ImuEncoder enc(layout);
  std::vector<CanFrame> frames;
  for (std::size_t k = 0; k < samples.size(); ++k)
    enc.encode(samples[k], 0xFFFFFFFDULL + k, enc.goodStatus(), &frames);
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 10U);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  // Time stamps wrapped: decoded time keeps increasing by one period.
  for (std::size_t k = 1; k < out.size(); ++k)
    EXPECT_NEAR(out[k].sample.t - out[k - 1].sample.t, layout.sample_period_s, 1.5e-6);
  EXPECT_EQ(out[5].sequence, 0x100000002ULL);
}

// Frames of samples[k] with counter counter0 + k (wrapping at the counter's width) and a
// receive time rx0 + k x rx_period: a stream as a socket delivers it.
void appendStream(const ImuLayout& layout, const nav::ImuSamples& samples, std::uint64_t counter0,
                  double rx0, double rx_period, std::vector<CanFrame>* frames) {
  ImuEncoder enc(layout);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const std::size_t first = frames->size();
    enc.encode(samples[k], counter0 + k, enc.goodStatus(), frames);
    for (std::size_t i = first; i < frames->size(); ++i) {
      (*frames)[i].rx_time_s = rx0 + static_cast<double>(k) * rx_period;
    }
  }
}

constexpr double kRx0 = 1.7e9;  // a CLOCK_REALTIME receive time

// Issue 17, defect 4: an IMU that restarts (counter and time from 0) mid-run is a restart,
// not a 2^32 wrap: counted, described, and the time axis continues after the silence.
TEST(ImuDecoder, RestartReBasesTheTimeAxis) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const double p = layout.sample_period_s;
  std::vector<CanFrame> frames;
  appendStream(layout, makeSamples(2000, p), 0, kRx0, p, &frames);
  // 200 ms of silence, then the IMU counts anew: counter 0, time stamp one period.
  const double rx_restart = kRx0 + 1999 * p + 0.2;
  appendStream(layout, makeSamples(1000, p, 9), 0, rx_restart, p, &frames);
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 3000U);
  EXPECT_EQ(dec.counters().restarts, 1U);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  EXPECT_NE(dec.lastRestart().find("counter 1999 -> 0"), std::string::npos) << dec.lastRestart();
  // The step across the restart is the silence (200 periods), every other step one period.
  EXPECT_NEAR(out[2000].sample.t - out[1999].sample.t, 0.2, 1.5e-6);
  EXPECT_EQ(out[2000].sequence - out[1999].sequence, 200U);
  for (std::size_t k = 1; k < out.size(); ++k) {
    if (k == 2000) continue;
    ASSERT_NEAR(out[k].sample.t - out[k - 1].sample.t, p, 1.5e-6) << k;
    ASSERT_EQ(out[k].sequence - out[k - 1].sequence, 1U) << k;
  }
}

// A layout without a counter: the time stamp alone going backwards is the restart.
TEST(ImuDecoder, RestartSeenFromTheTimeStampAlone) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const double p = layout.sample_period_s;
  std::vector<CanFrame> frames;
  appendStream(layout, makeSamples(500, p, 7, 100.0), 0, kRx0, p, &frames);
  appendStream(layout, makeSamples(100, p), 0, kRx0 + 499 * p + 1.0, p, &frames);
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 600U);
  EXPECT_EQ(dec.counters().restarts, 1U);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  EXPECT_NEAR(out[500].sample.t - out[499].sample.t, 1.0, 1.5e-6);
  EXPECT_NEAR(out[599].sample.t - out[500].sample.t, 99 * p, 1.5e-6);
}

// A true wrap of the 32-bit counter and the 2^32 us time stamp, judged against the receive
// clock, stays a wrap, also with the IMU's clock running 5x faster (the virtual bench's
// --time-scale) and the sender batching 25 samples per receive time.
TEST(ImuDecoder, WrapConsistentWithTheReceiveClockStaysAWrap) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const double p = layout.sample_period_s;
  const double t0 = 4294.967296 - 3000 * p;
  const auto samples = makeSamples(6000, p, 7, t0 - p);
  std::vector<CanFrame> frames;
  appendStream(layout, samples, 0xFFFFFFFFULL - 2999, kRx0, 0.0, &frames);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::size_t batch = i / 25;  // 25 samples' frames per receive time
    frames[i].rx_time_s = kRx0 + 0.005 * static_cast<double>(batch);
  }
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 6000U);
  EXPECT_EQ(dec.counters().restarts, 0U);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  for (std::size_t k = 1; k < out.size(); ++k) {
    ASSERT_NEAR(out[k].sample.t - out[k - 1].sample.t, p, 1.5e-6) << k;
  }
  EXPECT_EQ(out[3000].sequence, 0x100000000ULL);
}

// Crash resume across wraps (resolveTimeWraps): a daemon restarted after the IMU's time
// stamp wrapped sees a time below the run's end; a whole number of wraps the elapsed receive
// time explains continues the axis, anything else is refused with the reason.
constexpr double kWrap32us = 4294.967296;  // 2^32 x 1 us

TEST(ResolveTimeWraps, NoWrapWhenTheTimeIsPastTheRunsEnd) {
  const TimeWrapResolution r = resolveTimeWraps(120.0, 100.0, kWrap32us, 1e6, {});
  ASSERT_TRUE(r.wraps);
  EXPECT_EQ(*r.wraps, 0U);
  EXPECT_TRUE(r.why.empty());
}

TEST(ResolveTimeWraps, OneWrapWhileTheDaemonWasDown) {
  // The run ended 10 s before the wrap; 22 s later the IMU is 12 s past it.
  const TimeWrapResolution r = resolveTimeWraps(12.0, kWrap32us - 10.0, kWrap32us, 22.0, {});
  ASSERT_TRUE(r.wraps) << r.why;
  EXPECT_EQ(*r.wraps, 1U);
  // Exactly at the wrap (the step is the elapsed time at the limit of the clock ratio).
  const TimeWrapResolution edge = resolveTimeWraps(0.0, kWrap32us - 4.5, kWrap32us, 2.0, {});
  ASSERT_TRUE(edge.wraps) << edge.why;
  EXPECT_EQ(*edge.wraps, 1U);
}

TEST(ResolveTimeWraps, TwoWrapsOfAFastClock) {
  // A 16-bit ms time stamp (65.536 s). The old daemon's axis had wrapped once (the run ends at
  // 125.536 s, 5.536 s before its second wrap); the IMU's clock runs 3x the receive clock
  // (ratio 4 allowed) and the daemon was down 12 s: 36 s of IMU time, across that second
  // wrap. The new decoder counts from epoch 0 (30.464 s): two wraps continue the axis.
  ImuDecoderOptions o;
  o.max_clock_ratio = 4.0;
  const double w = 65.536;
  const double t_end = w + 60.0;
  const double t_now = t_end + 36.0 - 2 * w;
  const TimeWrapResolution r = resolveTimeWraps(t_now, t_end, w, 12.0, o);
  ASSERT_TRUE(r.wraps) << r.why;
  EXPECT_EQ(*r.wraps, 2U);
  // Two wraps within the down time are never resolved: a step longer than one period leaves
  // the step one period shorter inside the limit too.
  const double t_far = t_end + 90.0 - 3 * w;  // 30 s at 3x: 90 s, across two wraps
  const TimeWrapResolution far = resolveTimeWraps(t_far, t_end, w, 30.0, o);
  EXPECT_FALSE(far.wraps);
  EXPECT_NE(far.why.find("2 to 3 wraps"), std::string::npos) << far.why;
}

TEST(ResolveTimeWraps, ImuPowerCycleRefused) {
  // The run ended at 4000.1 s; after 22 s down the IMU counts from 0 again (12.3 s): one
  // wrap would be a step of 607 s, not within 2 x 22 + 0.5 s of IMU time.
  const TimeWrapResolution r = resolveTimeWraps(12.3, 4000.1, kWrap32us, 22.0, {});
  EXPECT_FALSE(r.wraps);
  EXPECT_NE(r.why.find("the IMU time is 12.300 s, the run ends at 4000.100 s"), std::string::npos)
      << r.why;
  EXPECT_NE(r.why.find("no whole number of 4294.967 s wraps fits the 22.0 s"), std::string::npos)
      << r.why;
  // Behind the run's end without a wrapping time stamp (a float time): refused too.
  const TimeWrapResolution f = resolveTimeWraps(12.3, 4300.1, std::nullopt, 22.0, {});
  EXPECT_FALSE(f.wraps);
  EXPECT_NE(f.why.find("does not wrap"), std::string::npos) << f.why;
  // Equal times are no step forward.
  EXPECT_FALSE(resolveTimeWraps(100.0, 100.0, std::nullopt, 1.0, {}).wraps);
  // The same IMU time after a run that ended at 4300.1 s (the old daemon's axis had wrapped
  // once): the IMU simply counted on, 7.2 s in 22 s, one wrap of the axis continues it.
  const TimeWrapResolution on = resolveTimeWraps(12.3, 4300.1, kWrap32us, 22.0, {});
  ASSERT_TRUE(on.wraps) << on.why;
  EXPECT_EQ(*on.wraps, 1U);
}

TEST(ResolveTimeWraps, AmbiguousCountRefused) {
  // Down 1 h at clock ratio 2: up to 7200.5 s of IMU time, one or two 4295 s wraps fit.
  const TimeWrapResolution r = resolveTimeWraps(100.0, 4000.0, kWrap32us, 3600.0, {});
  EXPECT_FALSE(r.wraps);
  EXPECT_NE(r.why.find("1 to 2 wraps"), std::string::npos) << r.why;
  EXPECT_NE(r.why.find("ambiguous"), std::string::npos) << r.why;
  // The same wrap with the virtual bench's clock ratio 25 after 10 s: 250.5 s, one fits; a
  // ratio of 1000 after 10 s is again ambiguous.
  ImuDecoderOptions fast;
  fast.max_clock_ratio = 25.0;
  const TimeWrapResolution one = resolveTimeWraps(100.0, 4200.0, kWrap32us, 10.0, fast);
  ASSERT_TRUE(one.wraps) << one.why;
  EXPECT_EQ(*one.wraps, 1U);
  fast.max_clock_ratio = 1000.0;
  EXPECT_FALSE(resolveTimeWraps(100.0, 4200.0, kWrap32us, 10.0, fast).wraps);
  EXPECT_FALSE(resolveTimeWraps(100.0, 4200.0, kWrap32us, std::nan(""), {}).wraps);
  EXPECT_FALSE(resolveTimeWraps(std::nan(""), 4200.0, kWrap32us, 10.0, {}).wraps);
  EXPECT_FALSE(resolveTimeWraps(100.0, 1e300, kWrap32us, 1e300, {}).wraps);
}

// The decoder's time axis shifted by whole wraps continues the old one: a stream that began
// (for this decoder) after its 2^32 us time stamp wrapped once is re-based by one wrap period,
// its sequence (the 32-bit counter) is left alone, and later wraps unwrap as before.
TEST(ImuDecoder, ShiftTimeWrapsContinuesTheAxis) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const double p = layout.sample_period_s;
  ImuDecoder dec(layout);
  ASSERT_TRUE(dec.timeWrapPeriod());
  EXPECT_NEAR(*dec.timeWrapPeriod(), kWrap32us, 1e-9);
  std::vector<CanFrame> frames;
  appendStream(layout, makeSamples(10, p, 7, 1.0), 500, kRx0, p, &frames);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 10U);
  const double t_before = out.back().sample.t;
  const std::uint64_t seq_before = out.back().sequence;
  dec.shiftTimeWraps(1);
  frames.clear();
  appendStream(layout, makeSamples(10, p, 7, 1.0 + 10 * p), 510, kRx0 + 10 * p, p, &frames);
  out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), 10U);
  EXPECT_NEAR(out[0].sample.t - t_before, kWrap32us + p, 1.5e-6);
  EXPECT_EQ(out[0].sequence, seq_before + 1);
  EXPECT_EQ(dec.counters().restarts, 0U);
  for (std::size_t k = 1; k < out.size(); ++k)
    EXPECT_NEAR(out[k].sample.t - out[k - 1].sample.t, p, 1.5e-6);
}

// Without a counter the integer time stamp is the sequence: it moves on by 2^bits counts.
TEST(ImuDecoder, ShiftTimeWrapsMovesATimeStampSequence) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const double p = layout.sample_period_s;
  ImuDecoder dec(layout);
  const std::optional<double> w = dec.timeWrapPeriod();
  ASSERT_TRUE(w);
  std::vector<CanFrame> frames;
  appendStream(layout, makeSamples(5, p, 7, 100.0), 0, kRx0, p, &frames);
  std::vector<DecodedImuSample> before = decodeAll(dec, frames);
  ASSERT_EQ(before.size(), 5U);
  dec.shiftTimeWraps(2);
  frames.clear();
  appendStream(layout, makeSamples(5, p, 7, 100.0 + 5 * p), 5, kRx0 + 5 * p, p, &frames);
  std::vector<DecodedImuSample> after = decodeAll(dec, frames);
  ASSERT_EQ(after.size(), 5U);
  EXPECT_NEAR(after[0].sample.t - before.back().sample.t, 2 * *w + p, 1e-5);
  const double periods = (2 * *w + p) / p;
  EXPECT_NEAR(static_cast<double>(after[0].sequence - before.back().sequence), periods, 1.0);
}

// Long silence with the counter running on (a cable pulled for 10 s): lost samples, no
// restart. A forward jump the receive clock cannot explain (1e6 samples within one period)
// is a restart, not a million lost samples.
TEST(ImuDecoder, ForwardStepsJudgedAgainstTheReceiveClock) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const double p = layout.sample_period_s;
  std::vector<CanFrame> frames;
  appendStream(layout, makeSamples(100, p), 0, kRx0, p, &frames);
  appendStream(layout, makeSamples(100, p, 7, 10.1), 10100, kRx0 + 10.1, p, &frames);
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  EXPECT_EQ(dec.counters().restarts, 0U);
  EXPECT_EQ(dec.counters().lost_samples, 10000U);
  frames.clear();
  appendStream(layout, makeSamples(100, p, 7, 1000.2), 1000200, kRx0 + 10.2, p, &frames);
  out.clear();
  dec.feed(frames, &out);
  EXPECT_EQ(dec.counters().restarts, 1U);
  EXPECT_EQ(dec.counters().lost_samples, 10000U);
  ASSERT_EQ(out.size(), 100U);
  EXPECT_NEAR(out[0].sample.t, 10.201, 1e-5);  // 10.2 s + 1 ms of receive time
}

// The virtual IMU's restart fault and wrap start, decoded with receive times equal to the
// sample times: the wrap (at 1.5 s) stays a wrap, the restart (at 3 s, 200 samples silent) is one
// restart, and the decoded time axis has one 0.201 s step and no other irregularity.
TEST(VirtualImuCan, RestartFaultAndWrapStart) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const double p = layout.sample_period_s;
  const auto samples = makeSamples(5000, p);
  VirtualImuOptions options;
  options.interface = "unused";
  options.wrap_at_s = 1.5;
  options.faults.restart_at_s = 2.9995;       // sample 2999 (3.000 s) is the first not sent
  options.faults.restart_silence_s = 0.1995;  // ... and 3199 (3.200 s) the first after it
  VirtualImuCan v(layout, options);
  std::vector<CanFrame> frames;
  v.encodeSamples(samples, &frames);
  EXPECT_EQ(v.restarts(), 1U);
  ASSERT_EQ(frames.size(), 5000U - 200U);
  // Counter 2^32 - 1 at 1.499 s, 0 at 1.5 s (sample 1499); counter 0 again after the restart.
  EXPECT_EQ(extractRaw(layout.messages[0].signals[0].coding, frames[1498].data), 0xFFFFFFFFULL);
  EXPECT_EQ(extractRaw(layout.messages[0].signals[0].coding, frames[1499].data), 0U);
  EXPECT_EQ(extractRaw(layout.messages[0].signals[0].coding, frames[2999].data), 0U);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frames[i].rx_time_s = kRx0 + static_cast<double>(i < 2999 ? i : i + 200) * p;
  }
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  ASSERT_EQ(out.size(), frames.size());
  EXPECT_EQ(dec.counters().restarts, 1U);
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  for (std::size_t k = 1; k < out.size(); ++k) {
    ASSERT_NEAR(out[k].sample.t - out[k - 1].sample.t, k == 2999 ? 0.201 : p, 1.5e-6) << k;
  }
}

TEST(ImuDecoder, BadFramesCountedNotFatal) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const auto samples = makeSamples(100, layout.sample_period_s);
  auto frames = encodeAll(layout, samples, {});
  CanFrame wrong_len = frames[1];  // IMU_ACCEL with 2 bytes
  wrong_len.len = 2;
  CanFrame unknown = frames[0];
  unknown.id = 0x7FF;
  frames.insert(frames.begin() + 30, unknown);  // between samples
  frames.insert(frames.begin() + 60, wrong_len);
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  EXPECT_EQ(dec.counters().unknown_id, 1U);
  EXPECT_EQ(dec.counters().bad_length, 1U);
  EXPECT_EQ(out.size(), 100U);  // bad frames are skipped, every sample still assembles
  EXPECT_EQ(dec.counters().lost_samples, 0U);
  EXPECT_NE(dec.lastProblem().find("length 2, expected 6"), std::string::npos) << dec.lastProblem();
}

TEST(ImuDecoder, InjectedCorruptionAndBadStatus) {
  const ImuLayout layout = loadShipped("navgrade_fd.toml");
  const auto samples = makeSamples(1000, layout.sample_period_s);
  const auto frames =
      encodeAll(layout, samples, {.corrupt_frame_every = 20, .bad_status_every = 25});
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out = decodeAll(dec, frames);
  // 50 corrupted (25 wrong length, 25 unknown id), 40 bad status, 10 of them both.
  EXPECT_EQ(dec.counters().bad_length, 25U);
  EXPECT_EQ(dec.counters().unknown_id, 25U);
  EXPECT_EQ(dec.counters().bad_status, 30U);
  EXPECT_EQ(out.size(), 1000U - 50U - 30U);
  // Corrupted samples show as counter gaps; the last one (index 999) has no successor.
  EXPECT_EQ(dec.counters().lost_samples, 49U);
  for (const auto& d : out) EXPECT_EQ(d.status & 0xFF00U, 0U);
}

TEST(ImuDecoder, StoppedImuProducesNoMoreSamples) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const auto samples = makeSamples(100, layout.sample_period_s);
  const auto frames = encodeAll(layout, samples, {.stop_after = 40});
  EXPECT_EQ(frames.size(), 40U * 3U);
}

TEST(ImuDecoder, AssemblyRuleOutOfOrderFrames) {
  const ImuLayout layout = loadShipped("sbg_ecan.toml");
  const auto samples = makeSamples(3, layout.sample_period_s);
  auto frames = encodeAll(layout, samples, {});
  // Sample 0: gyro frame before info -> orphan; sample 1: accel repeated.
  std::vector<CanFrame> seq = {frames[2], frames[0], frames[1], frames[3], frames[4],
                               frames[4], frames[6], frames[7], frames[8]};
  ImuDecoder dec(layout);
  std::vector<DecodedImuSample> out;
  dec.feed(seq, &out);
  EXPECT_EQ(out.size(), 1U);                   // only sample 2 is complete
  EXPECT_EQ(dec.counters().incomplete, 3U);    // orphan gyro, sample 0 (no gyro), repeated accel
  EXPECT_EQ(dec.counters().lost_samples, 0U);  // no earlier complete sample to measure from
}

TEST(DbcParser, FloatSignalsAndExtendedIds) {
  const char* text = R"(VERSION ""
BU_: A
BO_ 2147484000 FLOATS: 16 A
 SG_ RATE_X : 0|32@1- (1,0) [-1e9|1e9] "deg/s" A
 SG_ DV_X : 64|64@1- (1,0) [-1e9|1e9] "m/s" A
SIG_VALTYPE_ 2147484000 RATE_X : 1;
SIG_VALTYPE_ 2147484000 DV_X : 2;
)";
  io::Diagnostics diag("floats.dbc");
  auto db = parseDbc(text, diag);
  ASSERT_TRUE(db) << diag.str();
  ASSERT_EQ(db->messages.size(), 1U);
  const DbcMessage& m = db->messages[0];
  EXPECT_TRUE(m.extended);
  EXPECT_EQ(m.id, 2147484000U & 0x1FFFFFFFU);
  EXPECT_EQ(m.findSignal("RATE_X")->coding.type, ValueType::kFloat32);
  EXPECT_EQ(m.findSignal("DV_X")->coding.type, ValueType::kFloat64);
  std::uint8_t d[64] = {};
  const float r = 12.5f;
  std::memcpy(d, &r, 4);
  EXPECT_DOUBLE_EQ(decodeSignal(m.findSignal("RATE_X")->coding, d), 12.5);
}

struct DbcError {
  const char* text;
  int line;
  const char* reason;
};

class DbcGrammarErrors : public ::testing::TestWithParam<DbcError> {};

TEST_P(DbcGrammarErrors, RefusedWithLineAndReason) {
  io::Diagnostics diag("bad.dbc");
  auto db = parseDbc(GetParam().text, diag);
  EXPECT_FALSE(db.has_value());
  ASSERT_FALSE(diag.ok());
  const std::string msg = diag.items().front().str();
  EXPECT_EQ(diag.items().front().line, GetParam().line) << msg;
  EXPECT_NE(msg.find(GetParam().reason), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("bad.dbc:" + std::to_string(GetParam().line), 0), 0U) << msg;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, DbcGrammarErrors,
    ::testing::Values(
        DbcError{"BO_ 100 M: 8 N\n SG_ S m0 : 0|8@1+ (1,0) [0|1] \"\" N\n", 2,
                 "multiplexed signals"},
        DbcError{"BU_: N\nFOO_ 1 2;\n", 2, "unknown or unsupported statement 'FOO_'"},
        DbcError{"SG_ S : 0|8@1+ (1,0) [0|1] \"\" N\n", 1, "SG_ outside a BO_"},
        DbcError{"BO_ 100 M: 8 N\n SG_ S : 0|8@2+ (1,0) [0|1] \"\" N\n", 2, "byte order and sign"},
        DbcError{"BO_ 100 M: 2 N\n\n SG_ S : 8|16@1+ (1,0) [0|1] \"\" N\n", 3,
                 "needs 3 bytes but message 'M' is 2 bytes"},
        DbcError{"BO_ 100 M: 8 N\n SG_ S : 0|8@1+ (x,0) [0|1] \"\" N\n", 2,
                 "expected a number for the factor"},
        DbcError{"CM_ \"never closed;\n", 1, "unterminated string"},
        DbcError{"BO_ 4000 M: 8 N\n", 1, "exceeds 11 bits"},
        DbcError{"BO_ 100 M: 8 N\n SG_ S : 0|8@1+ (1,0) [0|1] \"\" N\nSG_MUL_VAL_ 100 S S 0-0;\n",
                 3, "SG_MUL_VAL_"},
        DbcError{"BO_ 100 M: 8 N\n SG_ S : 0|16@1+ (1,0) [0|1] \"\" N\nSIG_VALTYPE_ 100 S : 1;\n",
                 3, "must be 32 bits"}));

// A layout of one message with one signal, dtheta_x, its scale (line 12) written as `scale`.
std::string dthetaOnlyLayout(const std::string& scale) {
  return R"(format = "imubench-imu-can/1"
name = "x"
sample_period = "1 ms"
[[message]]
name = "A"
id = 0x100
length = 8
  [[message.signal]]
  quantity = "dtheta_x"
  byte = 0
  type = "i32"
  scale = ")" +
         scale + "\"\n";
}

TEST(ImuLayoutFile, DeviceFileErrorsNameLineAndReason) {
  const std::string text = dthetaOnlyLayout("1e-9 m/s");
  io::Diagnostics diag("imu.toml");
  auto l = parseImuLayout(text, ".", diag);
  EXPECT_FALSE(l.has_value());
  ASSERT_FALSE(diag.ok());
  const std::string msg = diag.str();
  EXPECT_NE(msg.find("imu.toml:12:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unit 'm/s' is not accepted for dtheta_x"), std::string::npos) << msg;
}

TEST(ImuLayoutFile, IncompleteLayoutRefused) {
  const std::string text = dthetaOnlyLayout("1e-9 rad");
  io::Diagnostics diag("imu.toml");
  EXPECT_FALSE(parseImuLayout(text, ".", diag).has_value());
  EXPECT_NE(diag.str().find("axis x: need exactly one of dvel or accel"), std::string::npos)
      << diag.str();
}

TEST(ImuLayoutFile, DbcMappingErrorsPointAtDeviceFile) {
  io::Diagnostics diag("m.toml");
  const std::string text = std::string(R"(format = "imubench-imu-can/1"
name = "x"
sample_period = "10 ms"
dbc = ")") + testing::deviceFile("sbg_ecan.dbc") +
                           R"("
[signals]
time = "IMU_INFO.NO_SUCH"
)";
  EXPECT_FALSE(parseImuLayout(text, ".", diag).has_value());
  EXPECT_NE(diag.str().find("m.toml:6:"), std::string::npos) << diag.str();
  EXPECT_NE(diag.str().find("IMU_INFO.NO_SUCH"), std::string::npos) << diag.str();
}

}  // namespace
}  // namespace imubench::drivers
