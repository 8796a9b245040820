// Scaling between SI values and Modbus registers as a device file's RegisterField describes
// them: 16/32-bit integers with an lsb, IEEE float32 in two registers, configurable word order.
// Used by the drivers (client side) and by the virtual devices (server side) alike.
#pragma once

#include <cstdint>

#include "drivers/device_file.h"

namespace imubench::drivers {

// Writes f.width() registers to out. Integer values are rounded and saturated to the type.
void encodeRegister(const RegisterField& f, WordOrder order, double si, uint16_t* out);
// Reads f.width() registers.
double decodeRegister(const RegisterField& f, WordOrder order, const uint16_t* in);
// Raw integer codes/bits (u16 code and status registers).
inline uint16_t encodeCode(int code) {
  return static_cast<uint16_t>(code);
}

}  // namespace imubench::drivers
