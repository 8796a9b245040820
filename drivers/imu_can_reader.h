// The IMU reader: a CanSocket feeding an ImuDecoder. Bad frames and lost samples are counted
// (decoder().counters()) and described (decoder().lastProblem()) for the caller to log; they
// never stop the reader.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/can_socket.h"
#include "drivers/imu_decoder.h"

namespace imubench::drivers {

struct ImuCanReaderOptions {
  std::string interface = "vcan0";  // SocketCAN interface name
  CanSocketOptions socket;          // defaults: FD on, 16 MiB receive buffer, kernel stamps
  std::size_t batch = 256;          // frames per recvmmsg call
  ImuDecoderOptions decoder;        // restart detection (defaults: see ImuDecoderOptions)
  bool IsValid(std::string* why) const;
};

class ImuCanReader {
 public:
  ImuCanReader(ImuLayout layout, ImuCanReaderOptions options);
  Status open();
  // Waits up to timeout_ms for frames, receives one batch and decodes it; completed samples
  // are appended to *out. Returns an error only for socket failures.
  Status poll(int timeout_ms, std::vector<DecodedImuSample>* out);
  // Frames received so far (including bad ones).
  std::uint64_t framesReceived() const { return decoder_.counters().frames; }
  const ImuDecoder& decoder() const { return decoder_; }
  // The decoder's ImuDecoder::shiftTimeWraps (a daemon resuming a run the IMU's time axis
  // wrapped in).
  void shiftTimeWraps(std::uint64_t wraps) { decoder_.shiftTimeWraps(wraps); }
  const CanSocket& socket() const { return socket_; }

 private:
  ImuDecoder decoder_;
  ImuCanReaderOptions options_;
  CanSocket socket_;
  std::vector<CanFrame> buffer_;
};

}  // namespace imubench::drivers
