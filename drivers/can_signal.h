// A signal inside a CAN payload, with DBC semantics (so device files and DBC files describe
// the same thing): start bit, length, byte order, signedness, integer or IEEE float, and the
// linear map physical = raw * factor + offset.
//
// Bit numbering (as in DBC files): bit b of the payload is bit (b % 8) of byte (b / 8), bit 0
// the least significant. Little-endian (Intel, DBC "@1") signals name their LEAST significant
// bit as start bit and grow upwards. Big-endian (Motorola, DBC "@0") signals name their MOST
// significant bit as start bit and grow downwards within a byte, then continue at bit 7 of the
// next byte ("sawtooth" numbering).
#pragma once

#include <cstdint>
#include <string>

namespace imubench::drivers {

enum class ByteOrder { kLittleEndian, kBigEndian };
enum class ValueType { kInteger, kFloat32, kFloat64 };

struct SignalCoding {
  int start_bit = 0;  // see the header comment
  int length = 8;     // bits: 1..64 for integers, 32 for kFloat32, 64 for kFloat64
  ByteOrder order = ByteOrder::kLittleEndian;
  bool is_signed = false;  // two's complement integers
  ValueType type = ValueType::kInteger;
  double factor = 1.0;  // physical = raw * factor + offset (SI units after unit conversion)
  double offset = 0.0;

  // One past the last payload byte the signal touches (frame length it needs); 0 when the
  // placement is impossible (the reason is in *why).
  int bytesNeeded(std::string* why = nullptr) const;
  bool IsValid(std::string* why) const;
};

// Raw bits of the signal (right-aligned, not sign-extended). data must hold 64 bytes.
std::uint64_t extractRaw(const SignalCoding& s, const std::uint8_t* data);
// Raw bits -> physical value (sign extension, float reinterpretation, factor and offset).
double rawToPhysical(const SignalCoding& s, std::uint64_t raw);
inline double decodeSignal(const SignalCoding& s, const std::uint8_t* data) {
  return rawToPhysical(s, extractRaw(s, data));
}
// Writes raw bits (low `length` bits of raw) into data (64 bytes).
void insertRaw(const SignalCoding& s, std::uint64_t raw, std::uint8_t* data);
// Physical value -> raw bits: rounds to the nearest step and saturates to the signal's range;
// returns false when it had to saturate. `wrap` instead keeps the low bits (for counters and
// time stamps that roll over).
bool physicalToRaw(const SignalCoding& s, double physical, bool wrap, std::uint64_t* raw);

}  // namespace imubench::drivers
