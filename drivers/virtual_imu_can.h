// Virtual IMU on SocketCAN: encodes samples (e.g. the simulator's) with an ImuLayout and sends
// each call's frames in one batched sendmmsg, so a caller that calls sendSamples() once per
// tick streams at high rates even under user-mode-linux. Fault injection for tests: dropped
// frames, corrupted frames (wrong length or unknown id), bad status, an IMU that stops.
//
// Typical use (inside a bench program's tick loop):
//   VirtualImuCan imu(layout, {.interface = "vcan0"});
//   if (Status s = imu.open(); !s.ok) ...;
//   imu.sendSamples(samples_due_this_tick);   // std::span<const nav::ImuSample>
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "drivers/can_socket.h"
#include "drivers/imu_encoder.h"

namespace imubench::drivers {

struct VirtualImuFaults {
  int drop_frame_every = 0;      // drop one frame of every Nth sample (0 = never)
  int corrupt_frame_every = 0;   // every Nth sample: one frame truncated or sent with unknown id
  int bad_status_every = 0;      // every Nth sample carries a failing status word
  std::int64_t stop_after = -1;  // stop sending after this many samples (-1 = never)
};

struct VirtualImuOptions {
  std::string interface = "vcan0";   // SocketCAN interface to send on
  VirtualImuFaults faults;           // none by default
  std::uint32_t unknown_id = 0x7E0;  // id used for "unknown id" corruption (not in the layout)
  bool IsValid(std::string* why) const;
};

class VirtualImuCan {
 public:
  VirtualImuCan(ImuLayout layout, VirtualImuOptions options);
  Status open();
  // Encodes and sends samples in one batch. The sample counter continues across calls.
  Status sendSamples(std::span<const nav::ImuSample> samples);
  // Encodes without sending (frames appended), applying the same counter and faults; for
  // tests and for writing logs.
  void encodeSamples(std::span<const nav::ImuSample> samples, std::vector<CanFrame>* out);
  void setFaults(const VirtualImuFaults& f) { options_.faults = f; }
  std::uint64_t samplesEncoded() const { return sequence_; }
  std::uint64_t framesSent() const { return frames_sent_; }
  bool stopped() const;
  const ImuEncoder& encoder() const { return encoder_; }

 private:
  ImuEncoder encoder_;
  VirtualImuOptions options_;
  CanSocket socket_;
  std::uint64_t sequence_ = 0;
  std::uint64_t frames_sent_ = 0;
  std::vector<CanFrame> frames_;
};

}  // namespace imubench::drivers
