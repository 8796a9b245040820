#include "drivers/imu_encoder.h"

#include <cassert>
#include <cmath>

namespace imubench::drivers {

ImuEncoder::ImuEncoder(ImuLayout layout) : layout_(std::move(layout)) {
  [[maybe_unused]] std::string why;
  assert(layout_.IsValid(&why));
  order_.push_back(layout_.start_message);
  for (int i = 0; i < static_cast<int>(layout_.messages.size()); ++i)
    if (i != layout_.start_message) order_.push_back(i);
}

ImuEncodeResult ImuEncoder::encode(const nav::ImuSample& s, std::uint64_t sequence,
                                   std::uint64_t status, std::vector<CanFrame>* out) const {
  ImuEncodeResult r;
  const double dt = layout_.sample_period_s;
  for (int mi : order_) {
    const ImuMessage& m = layout_.messages[static_cast<std::size_t>(mi)];
    CanFrame f;
    f.id = m.id;
    f.extended = m.extended;
    f.fd = m.fd;
    f.len = static_cast<std::uint8_t>(m.length);
    for (const ImuSignal& sig : m.signals) {
      double v = 0.0;
      bool wrap = false;
      const int qi = static_cast<int>(sig.quantity);
      switch (sig.quantity) {
        case ImuQuantity::kTime:
          v = s.t;
          wrap = true;
          break;
        case ImuQuantity::kCounter:
          v = static_cast<double>(sequence);
          wrap = true;
          break;
        case ImuQuantity::kStatus:
          v = static_cast<double>(status);
          break;
        case ImuQuantity::kTemperature:
          v = std::isnan(s.temp_c) ? 0.0 : s.temp_c;
          break;
        case ImuQuantity::kDthetaX:
        case ImuQuantity::kDthetaY:
        case ImuQuantity::kDthetaZ:
          v = s.dtheta[qi - static_cast<int>(ImuQuantity::kDthetaX)];
          break;
        case ImuQuantity::kDvelX:
        case ImuQuantity::kDvelY:
        case ImuQuantity::kDvelZ:
          v = s.dvel[qi - static_cast<int>(ImuQuantity::kDvelX)];
          break;
        case ImuQuantity::kRateX:
        case ImuQuantity::kRateY:
        case ImuQuantity::kRateZ:
          v = s.dtheta[qi - static_cast<int>(ImuQuantity::kRateX)] / dt;
          break;
        case ImuQuantity::kAccelX:
        case ImuQuantity::kAccelY:
        case ImuQuantity::kAccelZ:
          v = s.dvel[qi - static_cast<int>(ImuQuantity::kAccelX)] / dt;
          break;
        case ImuQuantity::kCount:
          break;
      }
      std::uint64_t raw = 0;
      if (sig.quantity == ImuQuantity::kCounter || sig.quantity == ImuQuantity::kStatus) {
        raw = sig.quantity == ImuQuantity::kCounter ? sequence : status;
      } else if (!physicalToRaw(sig.coding, v, wrap, &raw)) {
        r.saturated = true;
      }
      insertRaw(sig.coding, raw, f.data);
    }
    out->push_back(f);
    ++r.frames;
  }
  return r;
}

}  // namespace imubench::drivers
