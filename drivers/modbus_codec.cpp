#include "drivers/modbus_codec.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace imubench::drivers {

namespace {

void put32(WordOrder order, uint32_t v, uint16_t* out) {
  const auto hi = static_cast<uint16_t>(v >> 16);
  const auto lo = static_cast<uint16_t>(v & 0xFFFFu);
  out[0] = order == WordOrder::kHighFirst ? hi : lo;
  out[1] = order == WordOrder::kHighFirst ? lo : hi;
}

uint32_t get32(WordOrder order, const uint16_t* in) {
  const uint32_t a = in[0], b = in[1];
  return order == WordOrder::kHighFirst ? (a << 16) | b : (b << 16) | a;
}

template <class T>
T saturate(double counts) {
  if (!std::isfinite(counts)) return 0;
  const double r = std::round(counts);
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(std::clamp(r, lo, hi));
}

}  // namespace

void encodeRegister(const RegisterField& f, WordOrder order, double si, uint16_t* out) {
  const double counts = si / f.lsb;
  switch (f.type) {
    case RegisterType::kU16:
      out[0] = saturate<uint16_t>(counts);
      break;
    case RegisterType::kI16:
      out[0] = std::bit_cast<uint16_t>(saturate<int16_t>(counts));
      break;
    case RegisterType::kU32:
      put32(order, saturate<uint32_t>(counts), out);
      break;
    case RegisterType::kI32:
      put32(order, std::bit_cast<uint32_t>(saturate<int32_t>(counts)), out);
      break;
    case RegisterType::kF32:
      put32(order, std::bit_cast<uint32_t>(static_cast<float>(counts)), out);
      break;
  }
}

double decodeRegister(const RegisterField& f, WordOrder order, const uint16_t* in) {
  double counts = 0.0;
  switch (f.type) {
    case RegisterType::kU16:
      counts = in[0];
      break;
    case RegisterType::kI16:
      counts = std::bit_cast<int16_t>(in[0]);
      break;
    case RegisterType::kU32:
      counts = get32(order, in);
      break;
    case RegisterType::kI32:
      counts = std::bit_cast<int32_t>(get32(order, in));
      break;
    case RegisterType::kF32:
      counts = std::bit_cast<float>(get32(order, in));
      break;
  }
  return counts * f.lsb;
}

}  // namespace imubench::drivers
