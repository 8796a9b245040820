// Static-interval detection and recording sanity checks for raw IMU readings.
//
// Works on readings (rates / specific forces in any consistent unit, e.g. raw counts), not on
// increments, so it serves both the real third-party recordings and bench recordings
// (increments divided by their interval). Pure: no files, no printing.
//
// Detection: a centred moving window of the accelerometer (and optionally gyro) vector
// variance; the threshold is a multiple of the data's own quiet level (a low quantile of the
// windowed variance), so the same options fit raw counts and SI data alike.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/motion.h"
#include "nav/imu_sample.h"
#include "nav/rotation.h"

namespace imubench::calib {

// Time-aligned raw readings of both triads; sample i was taken at t[i].
struct RawImuData {
  std::vector<double> t;    // s, strictly increasing
  std::vector<Vec3> accel;  // accelerometer readings (unit of the source)
  std::vector<Vec3> gyro;   // gyro readings (unit of the source)
  std::size_t size() const { return t.size(); }
};

// A static span: samples [begin, end) of the series.
struct StaticSpan {
  std::size_t begin = 0;
  std::size_t end = 0;
  double t0 = 0.0;  // s, time of sample begin
  double t1 = 0.0;  // s, time of sample end - 1
  double duration() const { return t1 - t0; }
};

enum class RecordingStatusCode {
  kOk,
  kBadOptions,
  kEmpty,
  kSizeMismatch,
  kNonFinite,
  kTimeNotIncreasing,
  kMissingSegment,
  kSaturated,
  kTooShortStatic,
  kTooFewStatics,
};

const char* recordingStatusName(RecordingStatusCode code);

// The one Status (base/status.h) with the recording checks' code: ok exactly when the code is
// kOk; otherwise message names where (sample index / time) and why.
struct RecordingCheck : Status {
  RecordingStatusCode code = RecordingStatusCode::kOk;
  static RecordingCheck Ok() { return {}; }
  static RecordingCheck Error(RecordingStatusCode c, std::string why) {
    RecordingCheck r;
    r.ok = false;
    r.message = std::move(why);
    r.code = c;
    return r;
  }
};

struct StaticDetectionOptions {
  // Variance window, s: long enough to average sensor noise, short against a pose (imu_tk
  // uses ~1 s at 100 Hz).
  double window_s = 1.0;
  // Quantile of the windowed variance taken as the data's quiet level: most recordings are
  // at rest far more than 10 % of the time.
  double quiet_quantile = 0.1;
  // Static when the windowed variance is below factor * quiet level: noise variance scatters
  // by a factor ~2 between windows, hand/table motion raises it by orders of magnitude.
  double threshold_factor = 8.0;
  // Shortest span kept, s: shorter ones are pauses inside a motion and average too little.
  double min_duration_s = 2.0;
  // Also require the gyro to be quiet (same rule on the gyro variance): catches slow
  // rotations that barely disturb the accelerometer.
  bool use_gyro = true;

  bool IsValid(std::string* why) const;
};

struct StaticDetectionResult {
  RecordingCheck status;
  std::vector<StaticSpan> spans;
  double accel_quiet_variance = 0.0;  // quiet level found in the data (accel unit^2)
  double accel_threshold = 0.0;
};

StaticDetectionResult detectStaticSpans(const RawImuData& data,
                                        const StaticDetectionOptions& options = {});

struct RecordingCheckOptions {
  // A time step longer than this multiple of the median step is a missing segment: dropped
  // packets at 1-2 samples are tolerated, a lost second is not.
  double max_gap_factor = 5.0;
  // Saturation rails (readings at or beyond are clipped). Unset: not checked, because
  // physical-unit exports do not state their range.
  std::optional<double> accel_min, accel_max, gyro_min, gyro_max;

  bool IsValid(std::string* why) const;
};

// Refuses empty series, size mismatch, NaN/inf, non-increasing time, gaps and saturated
// samples, naming the first offending sample.
RecordingCheck checkRecording(const RawImuData& data, const RecordingCheckOptions& options = {});

// The same refusals for a bench recording of increments (nav::ImuSample, t = END of each
// interval): non-finite values, time not increasing, gaps (missing samples would bias a hold's
// mean and lose rotation inside a run), and samples at the IMU's range when the range is known.
struct IncrementCheckOptions {
  double max_gap_factor = 5.0;  // see RecordingCheckOptions
  // Symmetric ranges of the IMU (datasheet): a sample whose mean rate / specific force over
  // its interval reaches this magnitude on any axis is clipped. Unset: not checked (the
  // recording format does not state the range; `imubench calibrate --gyro-range/--accel-range`).
  std::optional<double> gyro_range_radps;
  std::optional<double> accel_range_mps2;

  bool IsValid(std::string* why) const;
};

// `what` names the recording in the reasons (e.g. "recording 2"). With `segments`, a gap is
// refused only where it harms: inside a segment, or next to a rotation (whose integration it
// would cut); a gap between holds, placements or unused stretches is harmless (a run resumed
// after a crash has one where the daemon was down). Without segments every gap is refused.
RecordingCheck checkIncrements(std::span<const nav::ImuSample> imu, const IncrementCheckOptions& o,
                               const std::string& what, std::span<const Segment> segments = {});

// The median interval between consecutive samples (0 for fewer than two): the recording's
// nominal step, against which checkIncrements and the explain analysis judge a gap.
double medianSampleStep(std::span<const nav::ImuSample> samples);

// Per-span mean of a series.
Vec3 spanMean(const std::vector<Vec3>& v, const StaticSpan& span);

}  // namespace imubench::calib
