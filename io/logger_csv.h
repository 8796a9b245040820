// Any logger's text/CSV into an imubench-csv/1 recording (`imubench import-csv`, docs/import.md):
// one file with accelerometer and gyro columns, or two files (gyro in the second) merged on
// time; delimiter and header detected or given; columns by header name or 1-based index;
// rates or increments; deg/s or rad/s, g or m/s^2, counts with scale factors; time from a
// column (s, ms, us, ns) or a given rate. The timing is measured (median interval, jitter,
// gaps) and reported; readings are resampled only when asked. Every bad row (not a number,
// NaN, wrong column count, time not increasing, no partner in the other file, implausible
// static specific force) is named at file:line; the import is refused unless the caller asks
// to leave the bad rows out, and then every row left out is listed. Nothing is dropped
// silently. Pure of printing: the caller prints the report.
//
// Conventions (interchange.md): a rate reading stamped t_k is taken as the mean over
// (t_{k-1}, t_k] (t is the END of the interval), so its increment is reading * (t_k - t_{k-1});
// the first row's interval is the median interval. The unit "g" is standard gravity
// 9.80665 m/s^2 (the unit's definition); the site's gravity is a separate option.
// The recording has no table angles: table.csv holds the header alone.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "io/recording.h"

namespace imubench::io {

// How a triad's (or the time's) numbers become SI: value_si = value * factor. `increment`:
// the columns hold integrals over the sample interval (rad, m/s), not rates.
struct ColumnUnit {
  double factor = 1.0;
  bool increment = false;
  std::string text;  // as given ("deg/s", "lsb:131:deg/s"), for the report
};

// Parses one unit term for a quantity: 'w' (gyro: rad/s, deg/s, rad, deg), 'a' (accelerometer:
// m/s^2, g, m/s), 't' (s, ms, us, ns); 'w' and 'a' also take "count:K:U" (K units U per count)
// and "lsb:N:U" (N counts per unit U). False with *why for anything else.
bool parseColumnUnit(char quantity, const std::string& text, ColumnUnit* unit, std::string* why);

// A column chosen by header name or by 1-based index (a plain integer is an index).
struct ColumnRef {
  std::string text;
};

struct LoggerImportOptions {
  std::string path;       // the file with the accelerometer (and, with one file, gyro) columns
  std::string gyro_path;  // empty: one file; else the gyro columns are in this file
  // Columns: "t" (time; absent when rate_hz is given), "wx","wy","wz","ax","ay","az",
  // optional "temp" (degC, in path), optional "gt" (the gyro file's time column; default "t").
  std::vector<std::pair<std::string, ColumnRef>> columns;
  ColumnUnit time_unit;  // of "t"/"gt"
  ColumnUnit gyro_unit;
  ColumnUnit accel_unit;
  std::optional<double> rate_hz;      // no time column: row k (from 0) at k / rate_hz
  std::optional<char> delimiter;      // unset: detected from the first rows (, ; tab | space)
  std::optional<bool> header;         // unset: detected (a first row with a non-number field)
  std::optional<double> resample_hz;  // set: readings resampled (area-preserving) to this rate
  // Two files merged on time: rows pair when their stamps differ by at most this fraction of
  // the median interval (loggers stamp both streams from one clock; a quarter interval
  // tolerates rounding of printed stamps and rejects the neighbouring sample).
  double match_fraction = 0.25;
  // Implausible static specific force: a row in a still, steady window (~0.2 s around it:
  // every gyro rate below static_rate_radps, far above a MEMS gyro bias; |f| varying by less
  // than 0.1 g) whose mean |f| is off gravity by more than static_force_tolerance g (0.5: a
  // unit error is x9.8 or /9.8, counts are far off; a shock or a turn is not steady and is not
  // judged). 0 turns it off.
  double static_rate_radps = 0.2;
  double static_force_tolerance = 0.5;
  bool skip_bad_rows = false;  // leave bad rows out (each listed) instead of refusing
  // meta.json
  double latitude_deg = 0.0;
  double height_m = 0.0;
  std::optional<double> gravity_mps2;
  std::string serial = "unknown";
};

struct BadRow {
  std::string file;
  long line = 0;
  std::string why;
  std::string where() const { return file + ":" + std::to_string(line); }
};

struct TimingGap {
  std::string file;
  long line = 0;  // the row after the gap
  double t0 = 0.0, t1 = 0.0;
};

struct TimingReport {
  double median_dt_s = 0.0;
  double rate_hz = 0.0;       // 1 / median
  double jitter_rms_s = 0.0;  // RMS of (dt - median) over the intervals that are not gaps
  double jitter_max_s = 0.0;  // largest |dt - median| over them
  double min_dt_s = 0.0, max_dt_s = 0.0;
  std::vector<TimingGap> gaps;  // intervals longer than 1.5 median
  bool from_rate = false;       // the time came from --rate, not a column
};

struct FileLayout {
  std::string path;
  char delimiter = ',';  // ' ' = runs of whitespace
  bool header = false;
  std::vector<std::string> names;  // header names (empty without a header)
  long data_rows = 0;
  long skipped_lines = 0;  // blank and comment ('#') lines
};

struct LoggerImport {
  Status status = Status::Error("not imported");  // refusal: the first reason; bad_rows: all
  Recording recording;
  std::vector<FileLayout> files;
  std::vector<BadRow> bad_rows;  // refused with them, or left out (skip_bad_rows)
  TimingReport timing;
  std::vector<std::string> notes;
};

LoggerImport importLogger(const LoggerImportOptions& options);

// The import report as JSON text for DIR/import.json (what was read, left out, measured).
std::string importReportJson(const LoggerImportOptions& options, const LoggerImport& result);

}  // namespace imubench::io
