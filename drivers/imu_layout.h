// How an IMU's samples travel over CAN: which messages, which signals, what each signal
// means, and how frames assemble into one sample. Built either from an imubench device file
// (TOML, byte offsets and widths) or from a DBC file plus a small TOML mapping file that names
// which DBC signal carries which quantity. Both produce the same ImuLayout, which the pure
// decoder (imu_decoder.h) and encoder (imu_encoder.h) use.
//
// Assembly rule (all layouts): a sample opens with the layout's start message (the one with
// the time stamp / counter) and closes when every message of the layout has arrived exactly
// once after it. A start message arriving before the sample closed, a repeated message, or a
// non-start message with no open sample makes the partial sample "incomplete" (counted, never
// delivered). Lost samples are counted from gaps in the counter (or, without a counter, the
// time stamp divided by the sample period).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/can_signal.h"
#include "io/toml_diagnostics.h"

namespace imubench::drivers {

// What a signal carries. Increments (dtheta, dvel) are per sample interval; rates (rate,
// accel) are averages over the interval and are multiplied by the sample period on decode.
enum class ImuQuantity : int {
  kTime,         // s, device time stamp of the sample (END of the interval)
  kCounter,      // sample counter (raw integer, +1 per sample, wraps at its width)
  kStatus,       // status bit field (raw)
  kTemperature,  // degC
  kDthetaX,
  kDthetaY,
  kDthetaZ,  // rad
  kDvelX,
  kDvelY,
  kDvelZ,  // m/s
  kRateX,
  kRateY,
  kRateZ,  // rad/s
  kAccelX,
  kAccelY,
  kAccelZ,  // m/s^2
  kCount
};
constexpr int kImuQuantityCount = static_cast<int>(ImuQuantity::kCount);

// "time", "counter", "status", "temperature", "dtheta_x", ..., "accel_z".
const char* imuQuantityName(ImuQuantity q);
std::optional<ImuQuantity> imuQuantityFromName(std::string_view name);

// SI factor of a unit for a quantity ("0.01 m/s^2" uses "m/s^2" -> 1). Accepted units:
//   time: s, ms, us; temperature: degC, C; dtheta: rad, mrad, urad, nrad, deg, arcsec;
//   dvel: m/s, mm/s, um/s; rate: rad/s, mrad/s, deg/s, deg/h; accel: m/s^2, m/s2, mm/s^2, g;
//   counter/status: "" or "1". Returns nullopt and sets *why for anything else.
std::optional<double> imuUnitToSi(ImuQuantity q, std::string_view unit, std::string* why);

struct ImuSignal {
  std::string name;
  ImuQuantity quantity = ImuQuantity::kStatus;
  SignalCoding coding;  // factor/offset already in SI units of the quantity
};

struct ImuMessage {
  std::string name;
  std::uint32_t id = 0;
  bool extended = false;
  bool fd = false;
  int length = 8;  // payload bytes the frame must have (shorter or longer frames are bad)
  std::vector<ImuSignal> signals;
};

struct ImuLayout {
  std::string name;               // human-readable device name
  std::string source;             // where the message definitions come from
  double sample_period_s = 0.01;  // nominal; converts rates to increments, times to counts
  std::vector<ImuMessage> messages;
  int start_message = 0;  // index into messages: the message that opens a sample
  // Status word checks: every bit of status_ok_mask must be set and no bit of
  // status_error_mask may be set, else the sample is rejected as bad status.
  std::uint64_t status_ok_mask = 0;
  std::uint64_t status_error_mask = 0;

  bool IsValid(std::string* why) const;
  // Finds the signal carrying q (nullptr when the layout has none) and its message index.
  const ImuSignal* find(ImuQuantity q, int* message_index = nullptr) const;
  // Half a quantisation step of a sample component in SI (rad, m/s, s, degC): the largest
  // difference between a value and its decoded copy. Rates and accelerations are converted
  // to increments (x sample period). Float signals report their relative precision at 1.0.
  double resolution(ImuQuantity q) const;
};

// Reads an imubench IMU device file (TOML). Relative "dbc" paths are taken relative to the
// device file's directory. Errors go to diag (file:line:column: reason).
std::optional<ImuLayout> loadImuLayoutFile(const std::string& path, io::Diagnostics& diag);
std::optional<ImuLayout> parseImuLayout(std::string_view toml_text, const std::string& base_dir,
                                        io::Diagnostics& diag);

}  // namespace imubench::drivers
