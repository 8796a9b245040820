#include "drivers/imu_decoder.h"

#include <cassert>
#include <cmath>
#include <cstdio>
#include <limits>

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

const char* frameVerdictName(FrameVerdict v) {
  switch (v) {
    case FrameVerdict::kAccepted:
      return "accepted";
    case FrameVerdict::kSampleDone:
      return "sample-done";
    case FrameVerdict::kBadLength:
      return "bad-length";
    case FrameVerdict::kUnknownId:
      return "unknown-id";
    case FrameVerdict::kBadStatus:
      return "bad-status";
    case FrameVerdict::kIncomplete:
      return "incomplete";
  }
  return "?";
}

ImuDecoder::ImuDecoder(ImuLayout layout) : layout_(std::move(layout)) {
  [[maybe_unused]] std::string why;
  assert(layout_.IsValid(&why));
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

std::uint64_t ImuDecoder::Unwrapper::operator()(std::uint64_t raw) {
  if (bits >= 64) return raw;
  if (have && raw < last) ++epoch;
  have = true;
  last = raw;
  return (epoch << bits) + raw;
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

FrameVerdict ImuDecoder::finish(double rx_time, std::vector<DecodedImuSample>* out) {
  const auto at = [this](ImuQuantity x) { return pending_[static_cast<std::size_t>(q(x))]; };
  DecodedImuSample d;
  d.rx_time_s = rx_time;
  // Sequence: unwrap, count gaps.
  std::uint64_t time_unwrapped = 0;
  if (time_is_integer_) time_unwrapped = time_unwrap_(pending_time_raw_);
  if (seq_quantity_ >= 0) {
    const std::uint64_t seq = seq_quantity_ == q(ImuQuantity::kCounter)
                                  ? counter_unwrap_(pending_counter_raw_)
                                  : time_unwrapped;
    if (have_last_) {
      const double steps = std::nearbyint(static_cast<double>(seq - last_seq_) / seq_step_);
      if (seq > last_seq_ && steps > 1.0) {
        const auto lost = static_cast<std::uint64_t>(steps - 1.0);
        counters_.lost_samples += lost;
        problem(std::to_string(lost) + " sample(s) lost before sequence " + std::to_string(seq));
      }
    }
    have_last_ = true;
    last_seq_ = seq;
    d.sequence = static_cast<std::uint64_t>(std::nearbyint(static_cast<double>(seq) / seq_step_));
  }
  if (has_time_) {
    d.sample.t = time_is_integer_ ? static_cast<double>(time_unwrapped) * time_coding_.factor +
                                        time_coding_.offset
                                  : at(ImuQuantity::kTime);
  } else if (seq_quantity_ == q(ImuQuantity::kCounter)) {
    d.sample.t = static_cast<double>(last_seq_) * layout_.sample_period_s;
  } else {
    d.sample.t = rx_time;
  }
  const double dt = layout_.sample_period_s;
  for (int axis = 0; axis < 3; ++axis) {
    const double th = pending_[static_cast<std::size_t>(q(ImuQuantity::kDthetaX) + axis)];
    const double rate = pending_[static_cast<std::size_t>(q(ImuQuantity::kRateX) + axis)];
    const double dv = pending_[static_cast<std::size_t>(q(ImuQuantity::kDvelX) + axis)];
    const double acc = pending_[static_cast<std::size_t>(q(ImuQuantity::kAccelX) + axis)];
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
