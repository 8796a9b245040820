// Virtual IMU on SocketCAN: encodes samples (e.g. the simulator's) with an ImuLayout and sends
// each call's frames in one batched sendmmsg, so a caller that calls sendSamples() once per
// tick streams at high rates even under user-mode-linux. Fault injection for tests: dropped
// frames, corrupted frames (wrong length or unknown id), bad status, an IMU that stops, an IMU
// that restarts (silent for a while, then counter and time stamp from 0), and a counter and
// time stamp that start just before their wrap.
//
// Typical use (inside a bench program's tick loop):
//   VirtualImuCan imu(layout, {.interface = "vcan0"});
//   if (Status s = imu.open(); !s.ok) ...;
//   imu.sendSamples(samples_due_this_tick);   // std::span<const nav::ImuSample>
#pragma once

#include <atomic>
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
  // Restart (brown-out, watchdog) at this sample time, s (-1 = never; requestRestart() any
  // time): the IMU is silent for restart_silence_s, then its counter and time stamp count
  // from 0 again.
  double restart_at_s = -1.0;
  double restart_silence_s = 0.2;  // sample time; a brown-out and reboot of a small IMU
};

struct VirtualImuOptions {
  std::string interface = "vcan0";   // SocketCAN interface to send on
  VirtualImuFaults faults;           // none by default
  std::uint32_t unknown_id = 0x7E0;  // id used for "unknown id" corruption (not in the layout)
  // The counter and an integer time stamp start so that both wrap at this sample time, s
  // (the layout's sample period sets the counter's start); -1: both start at 0. For tests of
  // the receiver's unwrapping.
  double wrap_at_s = -1.0;
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
  // Restarts the IMU at the next sample (as faults.restart_at_s does). Thread-safe: may be
  // called while another thread sends.
  void requestRestart() { restart_requested_ = true; }
  std::uint64_t restarts() const { return restarts_; }
  std::uint64_t samplesEncoded() const { return sequence_; }
  std::uint64_t framesSent() const { return frames_sent_; }
  bool stopped() const;
  const ImuEncoder& encoder() const { return encoder_; }

 private:
  bool silencedByRestart(const nav::ImuSample& s, std::uint64_t k);

  ImuEncoder encoder_;
  VirtualImuOptions options_;
  CanSocket socket_;
  std::uint64_t sequence_ = 0;
  std::uint64_t counter_shift_ = 0;  // sent counter = sample index + this (wrapping)
  double time_shift_ = 0.0;          // sent time stamp = sample time + this
  std::atomic<bool> restart_requested_{false};
  bool scheduled_restart_done_ = false;  // faults.restart_at_s has happened
  bool silent_ = false;                  // restarting: nothing sent before silent_until_
  double silent_until_ = 0.0;
  std::uint64_t restarts_ = 0;
  std::uint64_t frames_sent_ = 0;
  std::vector<CanFrame> frames_;
};

}  // namespace imubench::drivers
