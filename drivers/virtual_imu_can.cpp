#include "drivers/virtual_imu_can.h"

#include <cmath>

namespace imubench::drivers {

bool VirtualImuOptions::IsValid(std::string* why) const {
  if (interface.empty()) {
    if (why) *why = "interface name is empty";
    return false;
  }
  if (faults.drop_frame_every < 0 || faults.corrupt_frame_every < 0 ||
      faults.bad_status_every < 0) {
    if (why) *why = "fault periods must be >= 0";
    return false;
  }
  if (!(faults.restart_silence_s >= 0.0)) {
    if (why) *why = "restart_silence_s must be >= 0";
    return false;
  }
  return true;
}

VirtualImuCan::VirtualImuCan(ImuLayout layout, VirtualImuOptions options)
    : encoder_(std::move(layout)), options_(std::move(options)) {
  if (options_.wrap_at_s < 0.0) return;
  const ImuLayout& l = encoder_.layout();
  // Sample k is stamped (k + 1) periods: the counter reaches 2^bits at the sample stamped
  // wrap_at_s, and so does the time stamp (its range x its scale).
  if (const ImuSignal* c = l.find(ImuQuantity::kCounter)) {
    const auto k = static_cast<std::uint64_t>(std::llround(options_.wrap_at_s / l.sample_period_s));
    counter_shift_ = (c->coding.length >= 64 ? 0 : std::uint64_t{1} << c->coding.length) - k + 1;
  }
  if (const ImuSignal* t = l.find(ImuQuantity::kTime); t && t->coding.type == ValueType::kInteger) {
    time_shift_ = std::ldexp(1.0, t->coding.length) * t->coding.factor - options_.wrap_at_s;
  }
}

Status VirtualImuCan::open() {
  std::string why;
  if (!options_.IsValid(&why)) return Status::Error("virtual IMU options: " + why);
  for (const auto& m : encoder_.layout().messages)
    if (m.id == options_.unknown_id && !m.extended)
      return Status::Error("virtual IMU: unknown_id collides with message " + m.name);
  CanSocketOptions so;
  so.receive_buffer_bytes = 0;  // send only
  so.kernel_timestamps = false;
  so.fd = true;
  return socket_.open(options_.interface, so);
}

bool VirtualImuCan::stopped() const {
  return options_.faults.stop_after >= 0 &&
         sequence_ >= static_cast<std::uint64_t>(options_.faults.stop_after);
}

// A restart (requested, or scheduled by faults.restart_at_s) silences the IMU for
// restart_silence_s of sample time; the first sample after it is counter 0, time stamp one
// period. True while silent.
bool VirtualImuCan::silencedByRestart(const nav::ImuSample& s, std::uint64_t k) {
  const VirtualImuFaults& f = options_.faults;
  const bool scheduled = f.restart_at_s >= 0.0 && !scheduled_restart_done_ && s.t >= f.restart_at_s;
  if (restart_requested_.exchange(false) || scheduled) {
    scheduled_restart_done_ = scheduled_restart_done_ || scheduled;
    silent_ = true;
    silent_until_ = s.t + f.restart_silence_s;
  }
  if (!silent_) return false;
  if (s.t < silent_until_) return true;
  silent_ = false;
  counter_shift_ = std::uint64_t{0} - k;
  time_shift_ = encoder_.layout().sample_period_s - s.t;
  ++restarts_;
  return false;
}

void VirtualImuCan::encodeSamples(std::span<const nav::ImuSample> samples,
                                  std::vector<CanFrame>* out) {
  const VirtualImuFaults& f = options_.faults;
  const auto every = [](int n, std::uint64_t k) {
    return n > 0 && (k + 1) % static_cast<std::uint64_t>(n) == 0;
  };
  for (const nav::ImuSample& s : samples) {
    if (stopped()) return;
    const std::uint64_t k = sequence_++;
    if (silencedByRestart(s, k)) continue;
    const std::uint64_t status =
        every(f.bad_status_every, k) ? ~encoder_.goodStatus() : encoder_.goodStatus();
    const std::size_t first = out->size();
    nav::ImuSample stamped = s;
    stamped.t += time_shift_;
    encoder_.encode(stamped, k + counter_shift_, status, out);
    const std::size_t n = out->size() - first;
    // Faults hit the sample's last frame, so the sample cannot complete.
    CanFrame& victim = (*out)[first + n - 1];
    if (every(f.corrupt_frame_every, k)) {
      if ((k / static_cast<std::uint64_t>(f.corrupt_frame_every)) % 2 == 0) {
        if (victim.fd) {
          victim.len = victim.len == 8 ? 12 : 8;
        } else {
          victim.len = static_cast<std::uint8_t>(victim.len > 0 ? victim.len - 1 : 1);
        }
      } else {
        victim.id = options_.unknown_id;
        victim.extended = false;
      }
    }
    if (every(f.drop_frame_every, k))
      out->erase(out->begin() + static_cast<std::ptrdiff_t>(first + n - 1));
  }
}

Status VirtualImuCan::sendSamples(std::span<const nav::ImuSample> samples) {
  frames_.clear();
  encodeSamples(samples, &frames_);
  std::size_t sent = 0;
  Status st = socket_.send(frames_, &sent);
  frames_sent_ += sent;
  return st;
}

}  // namespace imubench::drivers
