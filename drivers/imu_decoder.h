// Pure decoder: CAN frames in, IMU samples out, following an ImuLayout (imu_layout.h) and its
// assembly rule. No sockets, clocks or printing: the reader (imu_can_reader.h) feeds it frames
// from SocketCAN, tests and benchmarks feed it raw frames directly.
#pragma once

#include <array>
#include <cstdint>
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

class ImuDecoder {
 public:
  // layout must satisfy layout.IsValid() (checked by the loaders); asserted.
  explicit ImuDecoder(ImuLayout layout);

  // Feeds one frame; a completed sample is appended to *out.
  FrameVerdict feed(const CanFrame& frame, std::vector<DecodedImuSample>* out);
  // Feeds many frames; returns how many samples were appended.
  std::size_t feed(std::span<const CanFrame> frames, std::vector<DecodedImuSample>* out);

  const ImuDecoderCounters& counters() const { return counters_; }
  // The most recent problem (bad frame, bad status, broken assembly, counter gap) in words,
  // e.g. "frame 0x120: length 2, expected 8"; empty while there has been none. For logging.
  const std::string& lastProblem() const { return last_problem_; }
  std::uint64_t problemCount() const { return problem_count_; }
  const ImuLayout& layout() const { return layout_; }

 private:
  struct Slot {
    int quantity;
    SignalCoding coding;
  };
  struct Message {
    std::uint32_t key;  // id | extended flag
    int length;
    std::vector<Slot> slots;
  };
  void problem(std::string what);
  FrameVerdict finish(double rx_time, std::vector<DecodedImuSample>* out);

  // Unwraps a rolling integer (counter, time stamp) into a monotonic 64-bit value.
  struct Unwrapper {
    int bits = 64;
    bool have = false;
    std::uint64_t last = 0;
    std::uint64_t epoch = 0;
    std::uint64_t operator()(std::uint64_t raw);
  };

  ImuLayout layout_;
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
  std::uint64_t last_seq_ = 0;
  Unwrapper counter_unwrap_;
  Unwrapper time_unwrap_;
  bool time_is_integer_ = false;
  bool has_time_ = false;
  SignalCoding time_coding_;
  ImuDecoderCounters counters_;
  std::string last_problem_;
  std::uint64_t problem_count_ = 0;
};

}  // namespace imubench::drivers
