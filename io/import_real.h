// Readers for the two public real recordings used to check the scalar calibration:
//  - imu_tk (Tedaldi et al.) Xsens pair: two whitespace-separated text files, columns
//    t x y z, raw 16-bit counts, 100 Hz; accelerometer and gyro files share the timestamps;
//  - imucal example Ferraris session: CSV "n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z"
//    (deg/s, m/s^2) sampled at 102.4 Hz (imucal's examples/basic_ferraris.py calibrates this
//    session with compute(..., sampling_rate_hz=102.4); at that rate every *_rot section
//    integrates to one full turn), plus its section list JSON {"x_p": {"start", "end"}, ...};
//  - imu-calib (Mikov) six-column log: "ax ay az wx wy wz" in m/s^2 and rad/s, no time column.
// Every value must be a finite number: NaN, infinities, missing columns (a truncated row) and
// time that does not increase are refused at file:line.
// Readings stay in the source's units (counts, deg/s, m/s^2); the scalar calibration fits
// scale factors in reading units per SI unit. Malformed input is refused with file:line and
// the reason; nothing is guessed.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/static_detection.h"

namespace imubench::io {

struct RealImport {
  // ok with the data; otherwise the message is "file:line: reason".
  Status status = Status::Error("not read");
  calib::RawImuData data;
  std::string accel_unit;  // "count", "reading" (signed, unit not stated) or "m/s^2"
  std::string gyro_unit;   // "count", "reading", "deg/s" or "rad/s"
  // Every reading is >= 0: unsigned counts (imu_tk's 16-bit files), whose rails 0 and 65535
  // mark saturation. False for signed data, where negative readings are ordinary.
  bool unsigned_counts = false;
};

// imu_tk text pair (accelerometer file, gyro file). Rows must match one to one in time.
RealImport readImuTkPair(const std::string& accel_path, const std::string& gyro_path);

// imucal CSV; t = n_samples / rate_hz.
inline constexpr double kImucalExampleRateHz = 102.4;
RealImport readImucalCsv(const std::string& csv_path, double rate_hz = kImucalExampleRateHz);

// Whitespace text "ax ay az wx wy wz" (m/s^2, rad/s), one row per sample at rate_hz, no time
// column (imu-calib by A. Mikov, data/imu0.log: MPU-9150 at 100 Hz).
inline constexpr double kSixColumnLogRateHz = 100.0;
RealImport readSixColumnLog(const std::string& path, double rate_hz = kSixColumnLogRateHz);

struct LabelledRange {
  std::string name;       // "x_p", ..., "z_rot"
  std::size_t start = 0;  // sample index (n_samples), inclusive
  std::size_t end = 0;    // exclusive
};

struct SectionListImport {
  Status status = Status::Error("not read");  // the message names the file and why
  std::vector<LabelledRange> sections;        // in file order
};

// imucal section list JSON.
SectionListImport readImucalSectionList(const std::string& json_path);

}  // namespace imubench::io
