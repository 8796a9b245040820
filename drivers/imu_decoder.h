// Pure decoder: CAN frames in, IMU samples out, following an ImuLayout (imu_layout.h) and its
// assembly rule. No sockets, clocks or printing: the reader (imu_can_reader.h) feeds it frames
// from SocketCAN, tests and benchmarks feed it raw frames directly.
//
// Time axis: the counter and an integer time stamp are unwrapped at their width. Each step is
// judged against the frames' receive times: a forward step the receive clock can explain is
// the IMU's (a wrap, or lost samples); anything else (a backward jump, or a forward jump far
// beyond the elapsed receive time) is a restart of the IMU. A restart is counted and
// described, and the decoder re-bases: the sample time and sequence continue from the last
// sample's plus the elapsed receive time, in whole sample periods. Frames without a receive
// time (rx_time_s == 0: not from a socket) cannot be judged; every step is then taken as
// forward.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drivers/can_frame.h"
#include "drivers/imu_layout.h"
#include "nav/imu_sample.h"

namespace imubench::drivers {

struct DecodedImuSample {
  nav::ImuSample sample;       // t from the device time stamp (or counter x period, or rx time)
  std::uint64_t sequence = 0;  // unwrapped counter (or time stamp / period); 0 when neither
  std::uint64_t status = 0;    // raw status word (0 when the layout has none)
  double rx_time_s = 0.0;      // kernel receive time of the frame that closed the sample
};

struct ImuDecoderCounters {
  std::uint64_t frames = 0;        // frames fed
  std::uint64_t samples = 0;       // samples delivered
  std::uint64_t lost_samples = 0;  // samples missing from counter / time-stamp gaps
  std::uint64_t bad_length = 0;    // known id, wrong payload length
  std::uint64_t unknown_id = 0;    // id not in the layout
  std::uint64_t bad_status = 0;    // complete samples rejected by their status bits
  std::uint64_t incomplete = 0;    // partial samples dropped by the assembly rule
  std::uint64_t restarts = 0;      // IMU restarts (counter / time stamp jumped, re-based)
  std::uint64_t badFrames() const { return bad_length + unknown_id; }
};

enum class FrameVerdict {
  kAccepted,    // part of an open sample
  kSampleDone,  // closed a sample (delivered)
  kBadLength,
  kUnknownId,
  kBadStatus,   // closed a sample whose status bits reject it
  kIncomplete,  // broke the assembly rule: a partial sample was dropped
};
const char* frameVerdictName(FrameVerdict v);

struct ImuDecoderOptions {
  // How many times faster than the receive clock the IMU's clock may run over a silence. A
  // real IMU runs at the receive clock's rate (ppm apart); 2 leaves room for a slewed
  // receive clock and still tells a restart after a silence of S seconds from a wrap unless
  // the counter or time stamp was within 2 S + max_jitter_s of its wrap. (The virtual bench
  // runs its IMU --time-scale times faster: a silence of its IMU that kept counting would be
  // taken for a restart, and re-based to the receive time.)
  double max_clock_ratio = 2.0;
  // Receive-time slack on top: a sender's batching and scheduling, kernel time stamp jitter.
  double max_jitter_s = 0.5;
  bool IsValid(std::string* why) const;
  // The longest forward step of the IMU's time that `elapsed_s` of receive time explains
  // (negative elapsed counts as 0): max_clock_ratio x elapsed + max_jitter_s.
  double maxStep(double elapsed_s) const;
};

// How many whole wraps of the IMU's time axis lie between a run's last stored sample (IMU
// time t_end_s) and the IMU's current sample (t_now_s, from a decoder that started after the
// run was interrupted, its own unwrapping from epoch 0). `wraps` is set when exactly one
// count k fits the decoder's own rule for a step (ImuDecoder: a forward step the receive
// clock explains): 0 < t_now_s + k W - t_end_s <= max_clock_ratio x elapsed_s + max_jitter_s,
// with k = 0 when the current time is already past the run's end (no wrap to account for).
// Otherwise `why` says why the time axis cannot be continued: no wrap period (the time does
// not wrap), no count fits (the IMU restarted, e.g. a power cycle) or several fit (the time
// since the run's last sample is too long for the clock ratio to pin the count).
struct TimeWrapResolution {
  std::optional<std::uint64_t> wraps;  // set when resolved
  std::string why;                     // the refusal in words; empty when resolved
};
// wrap_period_s: ImuDecoder::timeWrapPeriod() (nullopt: the time stamp does not wrap);
// elapsed_s: an upper bound of the receive time from the run's last stored sample to now.
TimeWrapResolution resolveTimeWraps(double t_now_s, double t_end_s,
                                    std::optional<double> wrap_period_s, double elapsed_s,
                                    const ImuDecoderOptions& options);

class ImuDecoder {
 public:
  // layout must satisfy layout.IsValid() (checked by the loaders) and options
  // options.IsValid(); both asserted.
  explicit ImuDecoder(ImuLayout layout, ImuDecoderOptions options = {});

  // Feeds one frame; a completed sample is appended to *out.
  FrameVerdict feed(const CanFrame& frame, std::vector<DecodedImuSample>* out);
  // Feeds many frames; returns how many samples were appended.
  std::size_t feed(std::span<const CanFrame> frames, std::vector<DecodedImuSample>* out);

  const ImuDecoderCounters& counters() const { return counters_; }
  // The most recent problem (bad frame, bad status, broken assembly, counter gap) in words,
  // e.g. "frame 0x120: length 2, expected 8"; empty while there has been none. For logging.
  const std::string& lastProblem() const { return last_problem_; }
  std::uint64_t problemCount() const { return problem_count_; }
  // The most recent restart in words (counter and time before and after, the silence, where
  // the time axis continues); empty while there has been none.
  const std::string& lastRestart() const { return last_restart_; }
  const ImuLayout& layout() const { return layout_; }
  const ImuDecoderOptions& options() const { return options_; }

  // The period after which the time axis the IMU sends wraps, s: 2^bits x factor of an
  // integer time stamp, else (no time stamp) 2^bits x sample period of the counter; nullopt
  // when it does not wrap (a float time stamp, a 64-bit count, neither).
  std::optional<double> timeWrapPeriod() const;
  // Re-bases the time axis by `wraps` whole wrap periods (timeWrapPeriod(), which must be
  // set): every later sample's time is wraps x the period later, its sequence (when the
  // wrapping count is the sequence) wraps counts later. For a decoder started after the
  // stream it continues already wrapped (a daemon restarted mid-run: resolveTimeWraps).
  void shiftTimeWraps(std::uint64_t wraps);

 private:
  struct Slot {
    int quantity = 0;
    SignalCoding coding;
  };
  struct Message {
    std::uint32_t key;  // id | extended flag
    int length;
    std::vector<Slot> slots;
  };
  // Unwraps a rolling integer (counter, time stamp) into a monotonic 64-bit value.
  struct Unwrapper {
    int bits = 64;
    bool have = false;
    std::uint64_t last = 0;
    std::uint64_t epoch = 0;
    // The unwrapped value raw would get (a raw value below the last one is one wrap on).
    std::uint64_t peek(std::uint64_t raw) const;
    void take(std::uint64_t raw);     // raw is the next value
    void restart(std::uint64_t raw);  // raw starts a new count (no wraps yet)
  };
  // One sample's sequence and time as the device counts them (unwrapped, not re-based).
  struct DeviceStamp {
    std::uint64_t seq = 0;  // raw units (counter, or integer time stamp)
    double t = 0.0;         // s
  };

  void problem(std::string what);
  FrameVerdict finish(double rx_time, std::vector<DecodedImuSample>* out);
  DeviceStamp peekStamp() const;
  bool plausibleStep(const DeviceStamp& next, std::optional<double> rx_elapsed) const;
  void restart(std::optional<double> rx_elapsed);

  ImuLayout layout_;
  ImuDecoderOptions options_;
  std::vector<Message> messages_;
  std::uint32_t all_mask_ = 0;
  std::array<double, kImuQuantityCount> pending_{};
  std::uint64_t pending_counter_raw_ = 0;
  std::uint64_t pending_time_raw_ = 0;
  std::uint32_t seen_mask_ = 0;
  bool open_ = false;
  // Sequence (counter, else integer time stamp) and time bookkeeping.
  int seq_quantity_ = -1;  // kCounter, kTime, or -1
  double seq_step_ = 1.0;  // raw units per sample
  bool have_last_ = false;
  DeviceStamp last_;           // the last delivered sample's device stamp
  double last_rx_ = 0.0;       // and its receive time
  std::int64_t seq_base_ = 0;  // re-basing after restarts: sequence = device + seq_base_
  double time_base_ = 0.0;     // time = device + time_base_
  Unwrapper counter_unwrap_;
  Unwrapper time_unwrap_;
  bool time_is_integer_ = false;
  bool has_time_ = false;
  SignalCoding time_coding_;
  ImuDecoderCounters counters_;
  std::string last_problem_;
  std::string last_restart_;
  std::uint64_t problem_count_ = 0;
};

}  // namespace imubench::drivers
