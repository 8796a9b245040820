// One CAN or CAN FD frame as the IMU code sees it, independent of the socket API: the decoder
// and encoder are pure functions of these, so they run (and are tested) without a CAN bus.
#pragma once

#include <cstdint>

namespace imubench::drivers {

struct CanFrame {
  std::uint32_t id = 0;    // 11-bit or 29-bit identifier, no flag bits
  bool extended = false;   // 29-bit identifier (CAN 2.0B)
  bool fd = false;         // CAN FD frame (payload up to 64 bytes)
  std::uint8_t len = 0;    // payload bytes: 0..8 classic; 0..8,12,16,20,24,32,48,64 FD
  double rx_time_s = 0.0;  // kernel receive time (CLOCK_REALTIME, s); 0 when not received
  alignas(8) std::uint8_t data[64] = {};  // bytes past len are zero
};

// Valid CAN FD payload lengths round up to the next DLC step (e.g. 36 -> 48).
inline std::uint8_t canFdRoundUpLength(int len) {
  constexpr std::uint8_t kSteps[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  for (std::uint8_t s : kSteps)
    if (s >= len) return s;
  return 64;
}

}  // namespace imubench::drivers
