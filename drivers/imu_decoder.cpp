#include "drivers/imu_decoder.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "io/enum_names.h"

namespace imubench::drivers {
namespace {

constexpr std::uint32_t kExtendedKey = 0x80000000U;

std::uint32_t keyOf(std::uint32_t id, bool extended) {
  return id | (extended ? kExtendedKey : 0U);
}

std::string hexId(std::uint32_t id, bool extended) {
  char buf[16];
  std::snprintf(buf, sizeof buf, extended ? "0x%08X" : "0x%03X", id);
  return buf;
}

constexpr int q(ImuQuantity x) {
  return static_cast<int>(x);
}

}  // namespace

constexpr io::Named<FrameVerdict> kFrameVerdictNames[] = {
    {FrameVerdict::kAccepted, "accepted"},    {FrameVerdict::kSampleDone, "sample-done"},
    {FrameVerdict::kBadLength, "bad-length"}, {FrameVerdict::kUnknownId, "unknown-id"},
    {FrameVerdict::kBadStatus, "bad-status"}, {FrameVerdict::kIncomplete, "incomplete"},
};

const char* frameVerdictName(FrameVerdict v) {
  return io::nameOf(kFrameVerdictNames, v, "?");
}

bool ImuDecoderOptions::IsValid(std::string* why) const {
  if (!(max_clock_ratio >= 1.0)) {
    if (why) *why = "max_clock_ratio must be >= 1";
    return false;
  }
  if (!(max_jitter_s > 0.0)) {
    if (why) *why = "max_jitter_s must be positive";
    return false;
  }
  return true;
}

double ImuDecoderOptions::maxStep(double elapsed_s) const {
  return max_clock_ratio * std::max(elapsed_s, 0.0) + max_jitter_s;
}

TimeWrapResolution resolveTimeWraps(double t_now_s, double t_end_s,
                                    std::optional<double> wrap_period_s, double elapsed_s,
                                    const ImuDecoderOptions& options) {
  TimeWrapResolution r;
  if (t_now_s > t_end_s) {
    r.wraps = 0;
    return r;
  }
  const double elapsed = std::max(elapsed_s, 0.0);
  const double limit = options.maxStep(elapsed);
  char buf[320];
  // snprintf returns the length it would have written: clamped to what the buffer holds.
  const int wanted = std::snprintf(
      buf, sizeof buf, "the IMU time is %.3f s, the run ends at %.3f s", t_now_s, t_end_s);
  const std::size_t head = std::min(static_cast<std::size_t>(std::max(wanted, 0)), sizeof buf - 1);
  const auto tail = [&](const char* fmt, auto... args) {
    std::snprintf(buf + head, sizeof buf - head, fmt, args...);
    r.why = buf;
    return r;
  };
  if (!wrap_period_s || !(*wrap_period_s > 0.0)) {
    return tail("; its time stamp does not wrap: the IMU restarted");
  }
  if (!std::isfinite(elapsed_s)) {
    return tail("; the time since the run's last sample is unknown, and so is the wrap count");
  }
  const double w = *wrap_period_s;
  // Beyond 2^53 wraps a count is no longer whole in a double (and no IMU gets there).
  constexpr double kMaxWraps = 9007199254740992.0;
  if (!std::isfinite(t_now_s) || !std::isfinite(t_end_s) || (t_end_s - t_now_s) / w > kMaxWraps) {
    return tail("; no wrap count can join them");
  }
  // Smallest k >= 1 with a forward step, largest with a step the elapsed time explains.
  const double behind = t_end_s - t_now_s;  // >= 0
  const double k_lo = std::floor(behind / w) + 1.0;
  const double k_hi = std::floor((limit + behind) / w);
  if (k_hi < k_lo) {
    return tail(
        "; no whole number of %.3f s wraps fits the %.1f s since the run's last sample (at "
        "most %.1f s of IMU time at clock ratio %.3g): the IMU restarted",
        w, elapsed, limit, options.max_clock_ratio);
  }
  if (k_hi > k_lo) {
    return tail(
        "; %.0f to %.0f wraps of %.3f s all fit the %.1f s since the run's last sample (at "
        "most %.1f s of IMU time at clock ratio %.3g): the wrap count is ambiguous",
        k_lo, k_hi, w, elapsed, limit, options.max_clock_ratio);
  }
  r.wraps = static_cast<std::uint64_t>(k_lo);
  return r;
}

ImuDecoder::ImuDecoder(ImuLayout layout, ImuDecoderOptions options)
    : layout_(std::move(layout)), options_(options) {
  [[maybe_unused]] std::string why;
  assert(layout_.IsValid(&why));
  assert(options_.IsValid(&why));
  for (std::size_t i = 0; i < layout_.messages.size(); ++i) {
    const ImuMessage& m = layout_.messages[i];
    Message dm{keyOf(m.id, m.extended), m.length, {}};
    for (const auto& s : m.signals) dm.slots.push_back({static_cast<int>(s.quantity), s.coding});
    messages_.push_back(std::move(dm));
    all_mask_ |= 1U << i;
  }
  if (const ImuSignal* t = layout_.find(ImuQuantity::kTime)) {
    has_time_ = true;
    time_coding_ = t->coding;
    time_is_integer_ = t->coding.type == ValueType::kInteger;
    time_unwrap_.bits = t->coding.length;
  }
  if (const ImuSignal* c = layout_.find(ImuQuantity::kCounter)) {
    seq_quantity_ = q(ImuQuantity::kCounter);
    counter_unwrap_.bits = c->coding.length;
    seq_step_ = 1.0;
  } else if (time_is_integer_) {
    seq_quantity_ = q(ImuQuantity::kTime);
    seq_step_ = layout_.sample_period_s / time_coding_.factor;
  }
  pending_.fill(std::numeric_limits<double>::quiet_NaN());
}

std::uint64_t ImuDecoder::Unwrapper::peek(std::uint64_t raw) const {
  if (bits >= 64) return raw;
  const std::uint64_t e = have && raw < last ? epoch + 1 : epoch;
  return (e << bits) + raw;
}

void ImuDecoder::Unwrapper::take(std::uint64_t raw) {
  if (have && raw < last) ++epoch;
  have = true;
  last = raw;
}

void ImuDecoder::Unwrapper::restart(std::uint64_t raw) {
  have = true;
  last = raw;
  epoch = 0;
}

std::optional<double> ImuDecoder::timeWrapPeriod() const {
  if (has_time_) {
    if (!time_is_integer_ || time_unwrap_.bits >= 64) return std::nullopt;
    return std::ldexp(std::abs(time_coding_.factor), time_unwrap_.bits);
  }
  if (seq_quantity_ != q(ImuQuantity::kCounter) || counter_unwrap_.bits >= 64) return std::nullopt;
  return std::ldexp(layout_.sample_period_s, counter_unwrap_.bits);
}

void ImuDecoder::shiftTimeWraps(std::uint64_t wraps) {
  const std::optional<double> period = timeWrapPeriod();
  assert(period);
  if (!period || wraps == 0) return;
  time_base_ += static_cast<double>(wraps) * *period;
  // The sequence counts the wrapping quantity itself (a time stamp without a counter, or the
  // counter that is the time axis): it continues by the same wraps.
  const Unwrapper& wrapping = has_time_ ? time_unwrap_ : counter_unwrap_;
  const int wrapping_q = has_time_ ? q(ImuQuantity::kTime) : q(ImuQuantity::kCounter);
  if (seq_quantity_ == wrapping_q) {
    seq_base_ += static_cast<std::int64_t>(wraps << static_cast<unsigned>(wrapping.bits));
  }
}

void ImuDecoder::problem(std::string what) {
  ++problem_count_;
  last_problem_ = std::move(what);
}

std::size_t ImuDecoder::feed(std::span<const CanFrame> frames, std::vector<DecodedImuSample>* out) {
  const std::size_t before = out->size();
  for (const CanFrame& f : frames) feed(f, out);
  return out->size() - before;
}

FrameVerdict ImuDecoder::feed(const CanFrame& frame, std::vector<DecodedImuSample>* out) {
  ++counters_.frames;
  const std::uint32_t key = keyOf(frame.id, frame.extended);
  int index = -1;
  for (std::size_t i = 0; i < messages_.size(); ++i) {
    if (messages_[i].key == key) {
      index = static_cast<int>(i);
      break;
    }
  }
  if (index < 0) {
    ++counters_.unknown_id;
    problem("frame " + hexId(frame.id, frame.extended) + ": unknown id");
    return FrameVerdict::kUnknownId;
  }
  const Message& m = messages_[static_cast<std::size_t>(index)];
  if (frame.len != m.length) {
    ++counters_.bad_length;
    problem("frame " + hexId(frame.id, frame.extended) + " (" +
            layout_.messages[static_cast<std::size_t>(index)].name + "): length " +
            std::to_string(frame.len) + ", expected " + std::to_string(m.length));
    return FrameVerdict::kBadLength;
  }
  FrameVerdict verdict = FrameVerdict::kAccepted;
  const std::uint32_t bit = 1U << index;
  if (index == layout_.start_message) {
    if (open_) {
      ++counters_.incomplete;
      problem("sample dropped: a new start frame arrived before the sample was complete");
      verdict = FrameVerdict::kIncomplete;
    }
    open_ = true;
    seen_mask_ = 0;
  } else if (!open_ || (seen_mask_ & bit)) {
    ++counters_.incomplete;
    problem(std::string("frame ") + hexId(frame.id, frame.extended) +
            (open_ ? " repeated within one sample" : " arrived with no open sample"));
    open_ = false;
    seen_mask_ = 0;
    return FrameVerdict::kIncomplete;
  }
  seen_mask_ |= bit;
  for (const Slot& s : m.slots) {
    const std::uint64_t raw = extractRaw(s.coding, frame.data);
    if (s.quantity == q(ImuQuantity::kCounter)) pending_counter_raw_ = raw;
    if (s.quantity == q(ImuQuantity::kTime)) pending_time_raw_ = raw;
    pending_[static_cast<std::size_t>(s.quantity)] = rawToPhysical(s.coding, raw);
  }
  if (seen_mask_ != all_mask_) return verdict;
  open_ = false;
  seen_mask_ = 0;
  const FrameVerdict done = finish(frame.rx_time_s, out);
  return verdict == FrameVerdict::kIncomplete ? verdict : done;
}

// The pending sample's stamp as the device counts it, unwrapped past the last one.
ImuDecoder::DeviceStamp ImuDecoder::peekStamp() const {
  DeviceStamp d;
  const std::uint64_t time_unwrapped = time_is_integer_ ? time_unwrap_.peek(pending_time_raw_) : 0;
  if (seq_quantity_ == q(ImuQuantity::kCounter)) d.seq = counter_unwrap_.peek(pending_counter_raw_);
  if (seq_quantity_ == q(ImuQuantity::kTime)) d.seq = time_unwrapped;
  if (has_time_) {
    d.t = time_is_integer_
              ? static_cast<double>(time_unwrapped) * time_coding_.factor + time_coding_.offset
              : pending_[static_cast<std::size_t>(q(ImuQuantity::kTime))];
  } else {
    d.t = static_cast<double>(d.seq) * layout_.sample_period_s;
  }
  return d;
}

// A forward step of the sequence and the time stamp that the elapsed receive time explains
// (rx_elapsed: nullopt when the frames carry no receive time: then any step is taken).
bool ImuDecoder::plausibleStep(const DeviceStamp& next, std::optional<double> rx_elapsed) const {
  if (!rx_elapsed || (seq_quantity_ < 0 && !has_time_)) return true;
  const double limit = options_.maxStep(*rx_elapsed);
  if (seq_quantity_ >= 0) {
    if (next.seq <= last_.seq) return false;
    const double step_s =
        static_cast<double>(next.seq - last_.seq) / seq_step_ * layout_.sample_period_s;
    if (step_s > limit) return false;
  }
  const double dt = next.t - last_.t;
  return dt > 0.0 && dt <= limit;
}

// The IMU restarted: its counts start anew, and the time axis continues from the last
// sample's time plus the elapsed receive time in whole sample periods (at least one).
void ImuDecoder::restart(std::optional<double> rx_elapsed) {
  const DeviceStamp before = last_;
  const std::uint64_t counter_before = counter_unwrap_.last;
  const double period = layout_.sample_period_s;
  const double elapsed = std::max(rx_elapsed.value_or(0.0), 0.0);
  const double n = std::max(1.0, std::nearbyint(elapsed / period));
  const std::int64_t last_seq = static_cast<std::int64_t>(before.seq) + seq_base_;
  const double last_t = before.t + time_base_;
  counter_unwrap_.restart(pending_counter_raw_);
  time_unwrap_.restart(pending_time_raw_);
  const DeviceStamp fresh = peekStamp();
  seq_base_ = last_seq + std::llround(n * seq_step_) - static_cast<std::int64_t>(fresh.seq);
  time_base_ = last_t + n * period - fresh.t;
  ++counters_.restarts;
  std::string what = "IMU restarted: ";
  if (seq_quantity_ == q(ImuQuantity::kCounter)) {
    what += "counter " + std::to_string(counter_before) + " -> " +
            std::to_string(pending_counter_raw_) + ", ";
  }
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "time %.6f s -> %.6f s after %.3f s of receive time; the time axis continues at "
                "%.6f s",
                before.t, fresh.t, elapsed, last_t + n * period);
  last_restart_ = what + buf;
  problem(last_restart_);
}

FrameVerdict ImuDecoder::finish(double rx_time, std::vector<DecodedImuSample>* out) {
  const auto at = [this](ImuQuantity x) { return pending_[static_cast<std::size_t>(q(x))]; };
  DecodedImuSample d;
  d.rx_time_s = rx_time;
  // Sequence and time: unwrap, judge the step, count gaps or re-base after a restart.
  DeviceStamp next = peekStamp();
  if (have_last_) {
    std::optional<double> rx_elapsed;
    if (rx_time > 0.0 && last_rx_ > 0.0) rx_elapsed = rx_time - last_rx_;
    if (!plausibleStep(next, rx_elapsed)) {
      restart(rx_elapsed);
      next = peekStamp();
    } else if (seq_quantity_ >= 0) {
      const double steps = std::nearbyint(static_cast<double>(next.seq - last_.seq) / seq_step_);
      if (steps > 1.0) {
        const auto lost = static_cast<std::uint64_t>(steps - 1.0);
        counters_.lost_samples += lost;
        problem(std::to_string(lost) + " sample(s) lost before sequence " +
                std::to_string(next.seq));
      }
    }
  }
  counter_unwrap_.take(pending_counter_raw_);
  time_unwrap_.take(pending_time_raw_);
  have_last_ = true;
  last_ = next;
  last_rx_ = rx_time;
  if (seq_quantity_ >= 0) {
    const double seq = static_cast<double>(static_cast<std::int64_t>(next.seq) + seq_base_);
    d.sequence = static_cast<std::uint64_t>(std::nearbyint(seq / seq_step_));
  }
  d.sample.t = has_time_ || seq_quantity_ >= 0 ? next.t + time_base_ : rx_time;
  const double dt = layout_.sample_period_s;
  // The x, y, z quantities of a kind follow one another in ImuQuantity.
  const auto axisOf = [this](ImuQuantity x_quantity, int axis) {
    return pending_[static_cast<std::size_t>(q(x_quantity)) + static_cast<std::size_t>(axis)];
  };
  for (int axis = 0; axis < 3; ++axis) {
    const double th = axisOf(ImuQuantity::kDthetaX, axis);
    const double rate = axisOf(ImuQuantity::kRateX, axis);
    const double dv = axisOf(ImuQuantity::kDvelX, axis);
    const double acc = axisOf(ImuQuantity::kAccelX, axis);
    d.sample.dtheta[axis] = std::isnan(th) ? rate * dt : th;
    d.sample.dvel[axis] = std::isnan(dv) ? acc * dt : dv;
  }
  d.sample.temp_c = at(ImuQuantity::kTemperature);
  const double st = at(ImuQuantity::kStatus);
  d.status = std::isnan(st) ? 0 : static_cast<std::uint64_t>(st);
  if ((d.status & layout_.status_ok_mask) != layout_.status_ok_mask ||
      (d.status & layout_.status_error_mask) != 0) {
    ++counters_.bad_status;
    char buf[64];
    std::snprintf(buf, sizeof buf, "sample rejected: status 0x%llX",
                  static_cast<unsigned long long>(d.status));
    problem(buf);
    return FrameVerdict::kBadStatus;
  }
  ++counters_.samples;
  out->push_back(d);
  return FrameVerdict::kSampleDone;
}

}  // namespace imubench::drivers
