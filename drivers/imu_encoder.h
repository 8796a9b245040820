// Pure encoder, the decoder's inverse: IMU samples -> CAN frames for a layout. Used by the
// virtual IMU (virtual_imu_can.h), by tests that build raw frames, and by benchmarks.
#pragma once

#include <cstdint>
#include <vector>

#include "drivers/can_frame.h"
#include "drivers/imu_layout.h"
#include "nav/imu_sample.h"

namespace imubench::drivers {

struct ImuEncodeResult {
  int frames = 0;          // frames appended (one per layout message)
  bool saturated = false;  // some value did not fit its signal and was clipped
};

class ImuEncoder {
 public:
  explicit ImuEncoder(ImuLayout layout);  // layout must be valid (asserted)

  // Appends the frames of one sample, start message first, then the others in layout order.
  // sequence: the sample counter value (wraps at the counter's width); status: raw status
  // word. A NaN temperature is sent as 0 degC.
  ImuEncodeResult encode(const nav::ImuSample& s, std::uint64_t sequence, std::uint64_t status,
                         std::vector<CanFrame>* out) const;
  // Status word that passes the layout's checks (all ok bits set, no error bit).
  std::uint64_t goodStatus() const { return layout_.status_ok_mask; }
  int framesPerSample() const { return static_cast<int>(layout_.messages.size()); }
  const ImuLayout& layout() const { return layout_; }

 private:
  ImuLayout layout_;
  std::vector<int> order_;  // message indices, start message first
};

}  // namespace imubench::drivers
