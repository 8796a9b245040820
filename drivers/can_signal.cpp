#include "drivers/can_signal.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace imubench::drivers {
namespace {

static_assert(std::endian::native == std::endian::little,
              "payload loads assume a little-endian host");

constexpr int kPayloadBytes = 64;

// Linear bit index of the first bit in the signal's own order: LSB for little-endian, MSB
// (counted from the MSB of byte 0) for big-endian.
int firstLinearBit(const SignalCoding& s) {
  if (s.order == ByteOrder::kLittleEndian) return s.start_bit;
  return (s.start_bit / 8) * 8 + (7 - s.start_bit % 8);
}

std::uint64_t load8(const std::uint8_t* data, int byte0) {
  std::uint64_t v = 0;
  if (byte0 + 8 <= kPayloadBytes) {
    std::memcpy(&v, data + byte0, 8);
  } else {
    std::memcpy(&v, data + byte0, static_cast<std::size_t>(kPayloadBytes - byte0));
  }
  return v;
}

void store8(std::uint8_t* data, int byte0, std::uint64_t v) {
  if (byte0 + 8 <= kPayloadBytes) {
    std::memcpy(data + byte0, &v, 8);
  } else {
    std::memcpy(data + byte0, &v, static_cast<std::size_t>(kPayloadBytes - byte0));
  }
}

std::uint64_t lowMask(int len) {
  return len >= 64 ? ~0ULL : ((1ULL << len) - 1);
}

}  // namespace

int SignalCoding::bytesNeeded(std::string* why) const {
  if (length < 1 || length > 64) {
    if (why) *why = "signal length " + std::to_string(length) + " bits is outside 1..64";
    return 0;
  }
  if (start_bit < 0 || start_bit >= 8 * kPayloadBytes) {
    if (why) *why = "start bit " + std::to_string(start_bit) + " is outside the 64-byte payload";
    return 0;
  }
  const int last = firstLinearBit(*this) + length - 1;
  if (last >= 8 * kPayloadBytes) {
    if (why) *why = "signal runs past the end of a 64-byte payload";
    return 0;
  }
  return last / 8 + 1;
}

bool SignalCoding::IsValid(std::string* why) const {
  if (bytesNeeded(why) == 0) return false;
  if (type == ValueType::kFloat32 && length != 32) {
    if (why) *why = "a float32 signal must be 32 bits long";
    return false;
  }
  if (type == ValueType::kFloat64 && length != 64) {
    if (why) *why = "a float64 signal must be 64 bits long";
    return false;
  }
  if (!std::isfinite(factor) || factor == 0.0 || !std::isfinite(offset)) {
    if (why) *why = "factor must be finite and non-zero, offset finite";
    return false;
  }
  return true;
}

std::uint64_t extractRaw(const SignalCoding& s, const std::uint8_t* data) {
  const int first = firstLinearBit(s);
  const int byte0 = first / 8;
  const int shift = first % 8;
  if (shift + s.length <= 64) {
    const std::uint64_t v = load8(data, byte0);
    if (s.order == ByteOrder::kLittleEndian) return (v >> shift) & lowMask(s.length);
    const std::uint64_t be = __builtin_bswap64(v);
    return s.length == 64 ? be : (be << shift) >> (64 - s.length);
  }
  // Rare: the signal straddles nine bytes. Bit by bit.
  std::uint64_t raw = 0;
  for (int i = 0; i < s.length; ++i) {
    const int lin = first + i;
    if (s.order == ByteOrder::kLittleEndian) {
      raw |= static_cast<std::uint64_t>((data[lin / 8] >> (lin % 8)) & 1U) << i;
    } else {
      raw = (raw << 1) | ((data[lin / 8] >> (7 - lin % 8)) & 1U);
    }
  }
  return raw;
}

void insertRaw(const SignalCoding& s, std::uint64_t raw, std::uint8_t* data) {
  raw &= lowMask(s.length);
  const int first = firstLinearBit(s);
  const int byte0 = first / 8;
  const int shift = first % 8;
  if (shift + s.length <= 64) {
    std::uint64_t v = load8(data, byte0);
    if (s.order == ByteOrder::kLittleEndian) {
      v = (v & ~(lowMask(s.length) << shift)) | (raw << shift);
    } else {
      const int up = 64 - shift - s.length;  // distance of the signal's LSB from bit 0 (BE word)
      std::uint64_t be = __builtin_bswap64(v);
      be = (be & ~(lowMask(s.length) << up)) | (raw << up);
      v = __builtin_bswap64(be);
    }
    store8(data, byte0, v);
    return;
  }
  for (int i = 0; i < s.length; ++i) {
    const int lin = first + i;
    const unsigned bit = s.order == ByteOrder::kLittleEndian
                             ? static_cast<unsigned>((raw >> i) & 1U)
                             : static_cast<unsigned>((raw >> (s.length - 1 - i)) & 1U);
    const int pos = s.order == ByteOrder::kLittleEndian ? lin % 8 : 7 - lin % 8;
    data[lin / 8] = static_cast<std::uint8_t>((data[lin / 8] & ~(1U << pos)) | (bit << pos));
  }
}

double rawToPhysical(const SignalCoding& s, std::uint64_t raw) {
  double value = 0.0;
  switch (s.type) {
    case ValueType::kFloat32: {
      const auto bits = static_cast<std::uint32_t>(raw);
      value = static_cast<double>(std::bit_cast<float>(bits));
      break;
    }
    case ValueType::kFloat64:
      value = std::bit_cast<double>(raw);
      break;
    case ValueType::kInteger:
      if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1U)) {
        raw |= ~lowMask(s.length);  // sign-extend
      }
      value = s.is_signed ? static_cast<double>(static_cast<std::int64_t>(raw))
                          : static_cast<double>(raw);
      break;
  }
  return value * s.factor + s.offset;
}

bool physicalToRaw(const SignalCoding& s, double physical, bool wrap, std::uint64_t* raw) {
  const double scaled = (physical - s.offset) / s.factor;
  if (s.type == ValueType::kFloat32) {
    *raw = std::bit_cast<std::uint32_t>(static_cast<float>(scaled));
    return true;
  }
  if (s.type == ValueType::kFloat64) {
    *raw = std::bit_cast<std::uint64_t>(scaled);
    return true;
  }
  const double r = std::nearbyint(scaled);
  if (wrap) {
    // Counters and time stamps: keep the low bits of the (non-negative) integer.
    const double m = std::ldexp(1.0, s.length);
    double w = std::fmod(r, m);
    if (w < 0) w += m;
    *raw = static_cast<std::uint64_t>(w) & lowMask(s.length);
    return true;
  }
  double lo = 0.0;
  // Largest double below 2^64 for 64-bit signals (2^64 - 1 is not representable).
  double hi = s.length == 64 ? 18446744073709549568.0 : std::ldexp(1.0, s.length) - 1.0;
  if (s.is_signed) {
    lo = -std::ldexp(1.0, s.length - 1);
    hi = std::ldexp(1.0, s.length - 1) - 1.0;
  }
  bool ok = true;
  double c = r;
  if (!(c >= lo)) {  // also catches NaN
    c = lo;
    ok = false;
  } else if (c > hi) {
    c = hi;
    ok = false;
  }
  if (s.is_signed) {
    *raw = static_cast<std::uint64_t>(static_cast<std::int64_t>(c)) & lowMask(s.length);
  } else {
    *raw = static_cast<std::uint64_t>(c) & lowMask(s.length);
  }
  return ok;
}

}  // namespace imubench::drivers
