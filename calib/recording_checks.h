// Checks of a recording that come before any calibration or analysis, shared by every front
// end (calibrate, explain, the daemon's calibration): pure functions on a RecordingView (a
// table recording) or on raw readings (third-party recordings without table angles).
//   motionSupport          which attitudes (gravity directions in the body frame) and which
//                          rotations (about which body axes) the recording holds, and what
//                          that determines of the two triads: a recording whose motion cannot
//                          determine a calibration is refused instead of calibrated to noise;
//   checkRateConsistency   whether the time axis (the sampling rate a format without time
//                          stamps is read with) agrees with the data: the gyro's integrated
//                          rotation against the table's angle change, the static gyro norm
//                          against the Earth rate, or the scalar calibration's gyro scales
//                          against the reading unit;
//   checkCalibratedRanges  samples whose calibrated rate or specific force reaches the IMU's
//                          range (clipped), for any reading unit.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/recording_view.h"
#include "calib/sensor_model.h"
#include "calib/static_detection.h"

namespace imubench::calib {

struct MotionSupportOptions {
  // Two holds whose gravity directions (body frame) differ by less than this are one attitude
  // (hand placement repeats a face within a few degrees; distinct faces differ by >= 30 deg).
  double same_attitude_deg = 10.0;
  // An axis' scale and bias are separable when gravity's component along it spans at least
  // this (of -1..1) over the attitudes: the axis tilted well both ways (a six-face session and
  // the direct plan span 2; one orientation spans 0).
  double min_gravity_span = 1.0;
  // A gyro axis' scale needs at least this much rotation about it, rad (its body-frame
  // component summed over the recording): a quarter turn gives the scale to far better than
  // any rate error, a hand wobble of a few degrees gives nothing.
  double min_rotation_rad = 1.5707963267948966;
  // Two rotation increments whose axes (sign ignored) are closer than this are one axis.
  double same_axis_deg = 10.0;
  // IMU readings only: a sample turns when its rate exceeds this, rad/s (far above the Earth
  // rate and a MEMS bias, far below any deliberate rotation).
  double moving_rate_radps = 0.05;
};

struct MotionSupport {
  std::string source;           // "table angles" or "IMU readings"
  std::vector<Vec3> attitudes;  // distinct gravity directions (unit "up" in the body frame)
  // Per body axis: max - min of the up component over the holds and (table angles) every
  // attitude the motion passes through: the navigation-based method sees an axis swept
  // through gravity during a run.
  Vec3 gravity_span = Vec3::Zero();
  Vec3 rotation_rad = Vec3::Zero();  // per body axis: rotation about it, summed |component|
  int rotation_axes = 0;             // distinct rotation axes turned by at least min_rotation_rad
  // What it determines: accelerometer scale and bias per axis (gravity span), gyro scale per
  // axis (rotation about it).
  std::array<bool, 3> accel_axis{};
  std::array<bool, 3> gyro_axis{};
  bool determinesTriads() const;
  // One line for people: the counts and what is missing ("" when everything is determined).
  std::string describe() const;
  std::string missing() const;
};

// From the table angles (the attitudes the table sets, whatever the IMU did) when the view has
// them, else from the IMU's readings (holds: segments of kind kStatic).
MotionSupport motionSupport(const RecordingView& recording, const MotionSupportOptions& o = {});
// Third-party readings in SI units (m/s^2, rad/s) with their static spans.
MotionSupport motionSupport(const RawImuData& data, std::span<const StaticSpan> spans,
                            const MotionSupportOptions& o = {});

struct RateCheckOptions {
  // The data and the time axis agree when the measured/expected factor lies in this range:
  // sensor scale errors are percent-level; a wrong rate or unit is a factor (x2, x0.5, x57).
  double min_factor = 0.8;
  double max_factor = 1.25;
  // Static gyro norm against the Earth rate: judged only when the holds' rate norms agree to
  // this fraction of the Earth rate (a navigation-grade gyro whose bias is far below it).
  double earth_rate_agreement = 0.1;
  double min_hold_s = 4.0;  // holds shorter are not used for the Earth-rate check
};

struct RateConsistency {
  // Error (message naming the evidence and the option to check) when the data contradict the
  // time axis or unit; ok when they agree or nothing could be judged.
  Status status;
  bool judged = false;
  double factor = 1.0;   // measured / expected (1 when consistent)
  std::string evidence;  // what was compared
};

// Table recording: the gyro's integrated rotation over every rotate segment against the
// table's angle change over it; without rotations, the static gyro norm against the Earth
// rate (navigation-grade gyros only, see RateCheckOptions).
RateConsistency checkRateConsistency(const RecordingView& recording,
                                     const RateCheckOptions& o = {});
// Third-party recording: the scalar calibration's gyro scales (readings per rad/s) against
// the reading unit's nominal (57.3 for deg/s, 1 for rad/s). rate_option names the option the
// time axis came from (e.g. "--rate 50 Hz") for the message.
RateConsistency checkRateConsistency(const TriadModel& gyro, double nominal_readings_per_radps,
                                     const std::string& rate_option,
                                     const RateCheckOptions& o = {});
// Readings per rad/s of a gyro reading unit as the readers name it ("deg/s", "rad/s"); none
// for counts and unstated units.
std::optional<double> gyroReadingsPerRadps(const std::string& unit);

struct RangeCheckOptions {
  std::optional<double> gyro_range_radps;  // symmetric IMU ranges (datasheet)
  std::optional<double> accel_range_mps2;
};

// Samples whose calibrated input (TriadModel::input of the reading) reaches the range on any
// axis are clipped: refused (code kSaturated) naming the first one, its time and value.
RecordingCheck checkCalibratedRanges(const RawImuData& data, const TriadModel& accel,
                                     const TriadModel& gyro, const RangeCheckOptions& o);

// Distinct values among `values` (values closer than `tolerance` are one): a static hold of a
// noise-free recording has one, quantised data whose noise is below one step two; a real
// sensor's noise gives many. Resolution-limited data have no measurable noise floor.
int countDistinct(std::vector<double> values, double tolerance);
// Resolution-limited: at most this many distinct values in a typical static hold.
inline constexpr int kMaxResolutionValues = 2;

}  // namespace imubench::calib
