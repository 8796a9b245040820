#include "drivers/virtual_imu_can.h"

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
  return true;
}

VirtualImuCan::VirtualImuCan(ImuLayout layout, VirtualImuOptions options)
    : encoder_(std::move(layout)), options_(std::move(options)) {}

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

void VirtualImuCan::encodeSamples(std::span<const nav::ImuSample> samples,
                                  std::vector<CanFrame>* out) {
  const VirtualImuFaults& f = options_.faults;
  const auto every = [](int n, std::uint64_t k) {
    return n > 0 && (k + 1) % static_cast<std::uint64_t>(n) == 0;
  };
  for (const nav::ImuSample& s : samples) {
    if (stopped()) return;
    const std::uint64_t k = sequence_++;
    const std::uint64_t status =
        every(f.bad_status_every, k) ? ~encoder_.goodStatus() : encoder_.goodStatus();
    const std::size_t first = out->size();
    encoder_.encode(s, k, status, out);
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
