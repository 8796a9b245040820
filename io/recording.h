// Recordings in the `imubench-csv/1` directory form (../shared/docs/interchange.md):
// meta.json, imu.csv, table.csv, optional chamber.csv and segments.csv.
//
// The reader is strict: a malformed file is refused with "file:line: reason" and nothing is
// guessed. Numbers are written in the shortest form that reads back to the same double
// (std::to_chars), so readRecording(writeRecording(x)) == x bit-exactly.
//
// Recording is the file's value form: table angles and the site latitude stay in degrees as
// written (encoder readings), so the round trip is exact; tableAnglesRad() and site() convert
// to SI for the engine.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "calib/model/motion.h"
#include "nav/earth.h"
#include "nav/imu_sample.h"

namespace imubench::io {

inline constexpr const char* kRecordingFormat = "imubench-csv/1";

struct TableSample {
  double t = 0.0;  // s
  // Encoder angles, deg, in the axis order of calib/model/motion.h: two-axis [outer, inner,
  // unused], three-axis [outer, middle, inner].
  std::array<double, 3> angles_deg{0.0, 0.0, 0.0};
};

struct ChamberSample {
  double t = 0.0;           // s
  double setpoint_c = 0.0;  // degC
  double temp_c = 0.0;      // degC, measured
};

struct Recording {
  // meta.json
  double latitude_deg = 0.0;
  double height_m = 0.0;
  std::optional<double> gravity_mps2;  // measured site gravity; absent: WGS-84 normal gravity
  std::string imu_serial;
  double imu_rate_hz = 0.0;
  calib::TableKind table_kind = calib::TableKind::kTwoAxis;
  std::optional<double> outer_axis_heading_deg;  // two-axis only; absent means 90 (East)

  nav::ImuSamples imu;  // imu.csv, t strictly increasing
  // table.csv, t strictly increasing. Empty (the header alone) for a recording without table
  // angles: the IMU was not on a table (a logger's file imported by `imubench import-csv`).
  std::vector<TableSample> table;
  std::vector<ChamberSample> chamber;  // chamber.csv (empty: file absent)
  // segments.csv, or derived from the table motion when the file is absent. For kRotate the
  // axis and signed angle are filled from the table samples (the file does not carry them).
  std::vector<calib::Segment> segments;
  bool segments_from_file = false;  // true when segments.csv was present

  nav::Site site() const;
  double outerAxisHeadingDeg() const { return outer_axis_heading_deg.value_or(90.0); }
};

// The recording in value, valid only when ok().
using RecordingReadResult = Result<Recording>;

// Writes the directory (created if missing; existing files are overwritten). segments.csv is
// written when rec.segments is non-empty, chamber.csv when rec.chamber is non-empty.
// Refuses (status) values that cannot be read back: non-finite numbers, unsorted times.
Status writeRecording(const std::string& dir, const Recording& rec);

// Reads and validates the directory.
RecordingReadResult readRecording(const std::string& dir);

// ---- Segment derivation (pure) ----

struct SegmentDerivationOptions {
  // An axis is still when its encoder rate is below this; encoder quantisation and jitter
  // at rest stay well under it, the slowest plan rotations (>= 1 deg/s) well above.
  double still_rate_deg_s = 0.05;
  // A still span shorter than this is a pause inside a motion, not a static position (table
  // servo settling and direction reversals last a fraction of a second).
  double min_static_s = 1.0;

  bool IsValid(std::string* why) const;
};

// Splits the table history into static spans (all axes still for >= min_static_s) and motion
// spans between them. A motion span where exactly one axis turns is kRotate with that axis and
// its signed net angle (rad, unwrapped across +-180 deg encoder wraps); otherwise kMove.
// Labels are "static-N", "rotate-N", "move-N" (N counts from 1 per kind).
std::vector<calib::Segment> deriveSegments(calib::TableKind kind,
                                           const std::vector<TableSample>& table,
                                           const SegmentDerivationOptions& options = {});

// Signed net rotation (rad) of one axis between t0 and t1 from the table samples, unwrapped
// across encoder wraps; 0 when fewer than two samples fall inside.
double netAxisAngle(const std::vector<TableSample>& table, int axis, double t0, double t1);

// Encoder angles of one sample in rad (axisCount(kind) entries).
std::vector<double> tableAnglesRad(calib::TableKind kind, const TableSample& s);

}  // namespace imubench::io
