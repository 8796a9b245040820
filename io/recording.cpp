#include "io/recording.h"

#include <fast_float/fast_float.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string_view>
#include <system_error>

#include "io/csv_text.h"
#include "io/file_io.h"

namespace imubench::io {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kImuHeader = "t,dthx,dthy,dthz,dvx,dvy,dvz,temp";
constexpr std::string_view kTable2Header = "t,outer,inner";
constexpr std::string_view kTable3Header = "t,outer,middle,inner";
constexpr std::string_view kChamberHeader = "t,setpoint,temp";
constexpr std::string_view kSegmentsHeader = "t0,t1,kind,label";

std::string at(const std::string& file, long line, const std::string& why) {
  return file + ":" + std::to_string(line) + ": " + why;
}

// ---------------------------------------------------------------------------------------
// Reading

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

// Splits a line into exactly `expected` comma-separated fields (no quoting: numeric files).
// Returns false with *why on a different count.
bool splitFields(std::string_view line, std::string_view* fields, size_t expected,
                 std::string* why) {
  size_t count = 0;
  const char* p = line.data();
  const char* end = line.data() + line.size();
  while (true) {
    const char* comma = static_cast<const char*>(std::memchr(p, ',', static_cast<size_t>(end - p)));
    const char* stop = comma ? comma : end;
    if (count < expected) fields[count] = std::string_view(p, static_cast<size_t>(stop - p));
    ++count;
    if (!comma) break;
    p = comma + 1;
  }
  if (count != expected) {
    *why = "expected " + std::to_string(expected) + " fields, got " + std::to_string(count);
    return false;
  }
  return true;
}

// Checks time order; `t` must be strictly after `prev`.
bool checkTimeOrder(bool first, double prev, double t, std::string* why) {
  if (!first && !(t > prev)) {
    *why = "time " + fmtDouble(t) + " is not after the previous row's " + fmtDouble(prev) +
           " (times must strictly increase)";
    return false;
  }
  return true;
}

std::vector<std::string_view> columnNames(std::string_view header) {
  std::vector<std::string_view> names;
  size_t s = 0;
  while (true) {
    const size_t c = header.find(',', s);
    names.push_back(header.substr(s, c == std::string_view::npos ? std::string_view::npos : c - s));
    if (c == std::string_view::npos) break;
    s = c + 1;
  }
  return names;
}

// What a data row of a numeric CSV may be: `names.size()` (<= kMaxColumns) fields, all numbers
// (parseNumber) except an empty `empty_ok_column` (NaN). The reference for every row: the fast
// path below only accepts rows this accepts, and defers to it for the reason otherwise.
constexpr size_t kMaxColumns = 8;
bool parseRowStrict(std::string_view line, const std::vector<std::string_view>& names,
                    int empty_ok_column, double* values, std::string* why) {
  if (line.empty()) {
    *why = "empty line";
    return false;
  }
  std::array<std::string_view, kMaxColumns> fields;
  const size_t n = names.size();
  if (!splitFields(line, fields.data(), n, why)) return false;
  for (size_t i = 0; i < n; ++i) {
    if (static_cast<int>(i) == empty_ok_column && fields[i].empty()) {
      values[i] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    if (!parseNumber(fields[i], names[i], &values[i], why)) return false;
  }
  return true;
}

// One row straight from the text at p (whole lines up to end): n fields, each a finite number
// fast_float reads up to the next ',' (the last up to "\n", "\r\n", "\r" at the end, or the
// end), or an empty `empty_ok_column` (NaN). Returns the position after the row's line end, or
// nullptr for anything else (parseRowStrict then gives the verdict and the reason). fast_float
// and std::from_chars read the same grammar to the same correctly rounded value; they differ
// only in what they call out of range (fast_float: inf, refused here as non-finite; and 0 for
// an underflow, so a zero is read again by std::from_chars, which refuses an underflow).
const char* parseRowFast(const char* p, const char* end, size_t n, int empty_ok_column,
                         double* values) {
  for (size_t i = 0; i < n; ++i) {
    const bool last = i + 1 == n;
    const bool at_sep = p == end || *p == (last ? '\n' : ',') || (last && *p == '\r');
    if (static_cast<int>(i) == empty_ok_column && at_sep) {
      values[i] = std::numeric_limits<double>::quiet_NaN();
    } else {
      const auto r = fast_float::from_chars(p, end, values[i]);
      if (r.ec != std::errc() || !std::isfinite(values[i])) return nullptr;
      if (values[i] == 0.0) {
        const auto z = std::from_chars(p, r.ptr, values[i]);
        if (z.ec != std::errc() || z.ptr != r.ptr) return nullptr;
      }
      p = r.ptr;
    }
    if (!last) {
      if (p == end || *p != ',') return nullptr;
      ++p;
    }
  }
  if (p == end) return p;
  if (*p == '\n') return p + 1;
  if (*p == '\r' && p + 1 == end) return end;
  if (*p == '\r' && p[1] == '\n') return p + 2;
  return nullptr;
}

// Reads a numeric CSV file streaming (io/csv_text.h readLineBlocks: the file is never held
// whole; 1 h at 2 kHz is 1 GB of text): the header must match exactly, every row is parsed as
// parseRowStrict says, column 0 is the time and must strictly increase. row(values) receives
// each row; reserve(rows) once, after the first block, an estimate of the file's row count.
template <typename ReserveFn, typename RowFn>
Status readNumericCsv(const std::string& path, std::string_view header,
                      std::string_view what_header, int empty_ok_column, ReserveFn&& reserve,
                      RowFn&& row) {
  const auto names = columnNames(header);
  const size_t n = names.size();
  long line = 0;  // lines consumed; the header is line 1
  bool any = false;
  double last_t = 0.0;
  size_t bytes_seen = 0;
  size_t rows = 0;
  Status err = Status::Ok();
  std::array<double, kMaxColumns> v;
  auto fail = [&](std::string why) {
    err = Status::Error(at(path, line, why));
    return false;
  };
  auto st = readLineBlocks(path, [&](std::string_view text, size_t file_bytes) {
    const char* p = text.data();
    const char* const end = p + text.size();
    if (line == 0) {
      LineCursor cur(text);
      std::string_view first;
      cur.next(&first);
      ++line;
      if (first != header) {
        return fail("wrong header " + quoteForMessage(first) + ", expected '" +
                    std::string(header) + "'" + std::string(what_header));
      }
      const void* nl = std::memchr(p, '\n', text.size());
      p = nl ? static_cast<const char*>(nl) + 1 : end;
    }
    while (p < end) {
      ++line;
      const char* next = parseRowFast(p, end, n, empty_ok_column, v.data());
      if (!next) {
        const void* nl = std::memchr(p, '\n', static_cast<size_t>(end - p));
        const char* stop = nl ? static_cast<const char*>(nl) : end;
        const char* e = stop > p && stop[-1] == '\r' ? stop - 1 : stop;
        std::string why;
        if (!parseRowStrict(std::string_view(p, static_cast<size_t>(e - p)), names, empty_ok_column,
                            v.data(), &why)) {
          return fail(why);
        }
        next = nl ? stop + 1 : end;
      }
      std::string why;
      if (!checkTimeOrder(!any, last_t, v[0], &why)) return fail(why);
      any = true;
      last_t = v[0];
      row(v.data());
      ++rows;
      p = next;
    }
    if (bytes_seen == 0 && rows > 0) {
      const double per_row = static_cast<double>(text.size()) / static_cast<double>(rows);
      reserve(static_cast<size_t>(1.02 * static_cast<double>(file_bytes) / per_row) + 16);
    }
    bytes_seen += text.size();
    return true;
  });
  if (!st.ok) return st;
  if (!err.ok) return err;
  if (line == 0) {
    return Status::Error(at(path, 1, "empty file, expected header '" + std::string(header) + "'"));
  }
  return Status::Ok();
}

// imu.csv, the big one (7.2 M rows, 1 GB for 1 h at 2 kHz), read streaming into *out.
Status readImuCsv(const std::string& path, nav::ImuSamples* out) {
  out->clear();
  return readNumericCsv(
      path, kImuHeader, "", 7, [&](size_t rows) { out->reserve(rows); },
      [&](const double* v) {
        nav::ImuSample& s = out->emplace_back();
        s.t = v[0];
        s.dtheta = Vec3(v[1], v[2], v[3]);
        s.dvel = Vec3(v[4], v[5], v[6]);
        s.temp_c = v[7];
      });
}

std::optional<calib::SegmentKind> segmentKindFromName(std::string_view s) {
  if (s == "static") return calib::SegmentKind::kStatic;
  if (s == "rotate") return calib::SegmentKind::kRotate;
  if (s == "move") return calib::SegmentKind::kMove;
  if (s == "soak") return calib::SegmentKind::kSoak;
  return std::nullopt;
}

// Parses a label field: plain text without quotes/commas, or a double-quoted field with ""
// escapes.
bool parseLabel(std::string_view field, std::string* label, std::string* why) {
  if (field.empty() || field.front() != '"') {
    if (field.find_first_of(",\"") != std::string_view::npos) {
      *why = "label " + quoteForMessage(field) + " contains ',' or '\"' and is not quoted";
      return false;
    }
    *label = std::string(field);
    return true;
  }
  if (field.size() < 2 || field.back() != '"') {
    *why = "unterminated quoted label " + quoteForMessage(field);
    return false;
  }
  label->clear();
  for (size_t i = 1; i + 1 < field.size(); ++i) {
    if (field[i] == '"') {
      if (i + 2 < field.size() && field[i + 1] == '"') {
        label->push_back('"');
        ++i;
        continue;
      }
      *why = "stray quote inside quoted label " + quoteForMessage(field);
      return false;
    }
    label->push_back(field[i]);
  }
  return true;
}

Status readSegments(const std::string& path, std::string_view text,
                    std::vector<calib::Segment>* out) {
  LineCursor cur(text);
  std::string_view line;
  if (!cur.next(&line))
    return Status::Error(
        at(path, 1, "empty file, expected header '" + std::string(kSegmentsHeader) + "'"));
  if (line != kSegmentsHeader) {
    return Status::Error(at(path, 1,
                            "wrong header " + quoteForMessage(line) + ", expected '" +
                                std::string(kSegmentsHeader) + "'"));
  }
  std::string why;
  while (cur.next(&line)) {
    const long ln = cur.lineNo();
    if (line.empty()) return Status::Error(at(path, ln, "empty line"));
    // t0,t1,kind are unquoted; the label is everything after the third comma.
    std::array<std::string_view, 4> f;
    size_t s = 0;
    bool ok = true;
    for (int i = 0; i < 3; ++i) {
      const size_t c = line.find(',', s);
      if (c == std::string_view::npos) {
        ok = false;
        break;
      }
      f[static_cast<size_t>(i)] = line.substr(s, c - s);
      s = c + 1;
    }
    if (!ok) return Status::Error(at(path, ln, "expected 4 fields t0,t1,kind,label"));
    f[3] = line.substr(s);
    calib::Segment seg;
    if (!parseNumber(f[0], "t0", &seg.t0, &why) || !parseNumber(f[1], "t1", &seg.t1, &why)) {
      return Status::Error(at(path, ln, why));
    }
    if (!(seg.t1 > seg.t0)) {
      return Status::Error(
          at(path, ln, "t1 " + fmtDouble(seg.t1) + " is not after t0 " + fmtDouble(seg.t0)));
    }
    const auto kind = segmentKindFromName(f[2]);
    if (!kind) {
      return Status::Error(at(path, ln,
                              "unknown segment kind " + quoteForMessage(f[2]) +
                                  " (expected static, rotate, move or soak)"));
    }
    seg.kind = *kind;
    if (!parseLabel(f[3], &seg.label, &why)) return Status::Error(at(path, ln, why));
    if (!out->empty() && seg.t0 < out->back().t1) {
      return Status::Error(at(path, ln,
                              "segment starts at " + fmtDouble(seg.t0) +
                                  " before the previous one ends at " + fmtDouble(out->back().t1) +
                                  " (segments must be sorted and not overlap)"));
    }
    out->push_back(std::move(seg));
  }
  return Status::Ok();
}

// meta.json -------------------------------------------------------------------------------

using nlohmann::json;

const json* member(const json& obj, const char* key) {
  const auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

bool numberField(const json& obj, const std::string& path, const char* key, bool required,
                 std::optional<double>* out, std::string* why) {
  const json* v = member(obj, key);
  if (!v) {
    if (required) *why = "missing '" + path + key + "'";
    return !required;
  }
  if (!v->is_number()) {
    *why = "'" + path + key + "' must be a number, got " + v->dump();
    return false;
  }
  const double d = v->get<double>();
  if (!std::isfinite(d)) {
    *why = "'" + path + key + "' is not finite";
    return false;
  }
  *out = d;
  return true;
}

bool objectField(const json& obj, const char* key, const json** out, std::string* why) {
  const json* v = member(obj, key);
  if (!v) {
    *why = std::string("missing object '") + key + "'";
    return false;
  }
  if (!v->is_object()) {
    *why = std::string("'") + key + "' must be an object";
    return false;
  }
  *out = v;
  return true;
}

// Line (1-based) of a byte offset in text, for JSON syntax errors.
long lineOfByte(std::string_view text, size_t byte) {
  byte = std::min(byte, text.size());
  return 1 +
         static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(byte), '\n'));
}

Status readMeta(const std::string& path, const std::string& text, Recording* rec) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    return Status::Error(at(path, lineOfByte(text, e.byte == 0 ? 0 : e.byte - 1),
                            std::string("JSON syntax error: ") + e.what()));
  }
  std::string why;
  auto fail = [&](const std::string& w) { return Status::Error(path + ": " + w); };
  if (!j.is_object()) return fail("top level must be an object");
  const json* format = member(j, "format");
  if (!format) return fail("missing 'format' (expected \"" + std::string(kRecordingFormat) + "\")");
  if (!format->is_string() || format->get<std::string>() != kRecordingFormat) {
    return fail("unsupported format " + format->dump() + " (expected \"" +
                std::string(kRecordingFormat) + "\")");
  }
  const json* site = nullptr;
  const json* imu = nullptr;
  const json* table = nullptr;
  if (!objectField(j, "site", &site, &why) || !objectField(j, "imu", &imu, &why) ||
      !objectField(j, "table", &table, &why)) {
    return fail(why);
  }
  std::optional<double> lat, height, gravity, rate, heading;
  if (!numberField(*site, "site.", "latitude_deg", true, &lat, &why) ||
      !numberField(*site, "site.", "height_m", true, &height, &why) ||
      !numberField(*site, "site.", "gravity_mps2", false, &gravity, &why) ||
      !numberField(*imu, "imu.", "rate_hz", true, &rate, &why) ||
      !numberField(*table, "table.", "outer_axis_heading_deg", false, &heading, &why)) {
    return fail(why);
  }
  if (*lat < -90.0 || *lat > 90.0)
    return fail("'site.latitude_deg' " + fmtDouble(*lat) + " outside [-90, 90]");
  if (gravity && !(*gravity > 0.0)) return fail("'site.gravity_mps2' must be positive");
  if (!(*rate > 0.0)) return fail("'imu.rate_hz' must be positive");
  const json* serial = member(*imu, "serial");
  if (!serial) return fail("missing 'imu.serial'");
  if (!serial->is_string()) return fail("'imu.serial' must be a string, got " + serial->dump());
  const json* kind = member(*table, "kind");
  if (!kind) return fail("missing 'table.kind'");
  if (*kind == "two-axis") {
    rec->table_kind = calib::TableKind::kTwoAxis;
  } else if (*kind == "three-axis") {
    rec->table_kind = calib::TableKind::kThreeAxis;
    if (heading) return fail("'table.outer_axis_heading_deg' applies to two-axis tables only");
  } else {
    return fail("unknown 'table.kind' " + kind->dump() +
                " (expected \"two-axis\" or \"three-axis\")");
  }
  rec->latitude_deg = *lat;
  rec->height_m = *height;
  rec->gravity_mps2 = gravity;
  rec->imu_serial = serial->get<std::string>();
  rec->imu_rate_hz = *rate;
  rec->outer_axis_heading_deg = heading;
  return Status::Ok();
}

void fillRotateAxes(const std::vector<TableSample>& table, calib::TableKind kind,
                    std::vector<calib::Segment>* segments) {
  for (auto& s : *segments) {
    if (s.kind != calib::SegmentKind::kRotate) continue;
    double best = 0.0;
    s.axis = 0;
    for (int a = 0; a < calib::axisCount(kind); ++a) {
      const double ang = netAxisAngle(table, a, s.t0, s.t1);
      if (std::abs(ang) > std::abs(best)) {
        best = ang;
        s.axis = a;
      }
    }
    s.angle = best;
  }
}

// ---------------------------------------------------------------------------------------
// Writing

// Buffered writer of text with shortest round-trip doubles.
class CsvWriter {
 public:
  explicit CsvWriter(std::FILE* f) : f_(f) { buf_.reserve(kChunk + 256); }
  ~CsvWriter() = default;
  void text(std::string_view s) {
    buf_.append(s);
    maybeFlush();
  }
  void number(double v) {
    char tmp[64];
    const auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
    buf_.append(tmp, r.ptr);
  }
  void comma() { buf_.push_back(','); }
  void endLine() {
    buf_.push_back('\n');
    maybeFlush();
  }
  bool finish() {
    flush();
    return ok_ && std::fflush(f_) == 0;
  }

 private:
  static constexpr size_t kChunk = 1 << 20;
  void maybeFlush() {
    if (buf_.size() >= kChunk) flush();
  }
  void flush() {
    if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), f_) != buf_.size()) ok_ = false;
    buf_.clear();
  }
  std::FILE* f_;
  std::string buf_;
  bool ok_ = true;
};

template <typename Fn>
Status writeFile(const std::string& path, Fn&& body) {
  FilePtr f(std::fopen(path.c_str(), "wb"));
  if (!f) return Status::Error(path + ": cannot create: " + std::strerror(errno));
  CsvWriter w(f.get());
  body(w);
  if (!w.finish()) return Status::Error(path + ": write error: " + std::strerror(errno));
  if (std::fclose(f.release()) != 0)
    return Status::Error(path + ": close error: " + std::strerror(errno));
  return Status::Ok();
}

// A table file: its header line, then a line per row, each written by write_row (no line end).
template <class Rows, class WriteRow>
Status writeTable(const fs::path& path, std::string_view header, const Rows& rows,
                  WriteRow&& write_row) {
  return writeFile(path.string(), [&](CsvWriter& w) {
    w.text(header);
    w.endLine();
    for (const auto& row : rows) {
      write_row(w, row);
      w.endLine();
    }
  });
}

// An optional table file (chamber.csv, segments.csv): written when there are rows, otherwise
// removed, so that a directory written again says what the recording says.
template <class Rows, class WriteRow>
Status writeOptionalTable(const fs::path& path, std::string_view header, const Rows& rows,
                          WriteRow&& write_row) {
  if (!rows.empty()) return writeTable(path, header, rows, write_row);
  std::error_code ec;
  fs::remove(path, ec);
  return Status::Ok();
}

std::string quoteLabel(const std::string& label) {
  if (label.find_first_of(",\"\n\r") == std::string::npos &&
      (label.empty() || label.front() != '"')) {
    return label;
  }
  std::string r = "\"";
  for (char c : label) {
    if (c == '"') r += '"';
    r += c;
  }
  return r + "\"";
}

// Pre-write validation: everything written must read back.
Status validateForWrite(const Recording& rec) {
  auto bad = [](const std::string& what) {
    return Status::Error("cannot write recording: " + what);
  };
  if (!std::isfinite(rec.latitude_deg) || std::abs(rec.latitude_deg) > 90.0)
    return bad("latitude out of range");
  if (!std::isfinite(rec.height_m)) return bad("height not finite");
  if (!(rec.imu_rate_hz > 0.0) || !std::isfinite(rec.imu_rate_hz))
    return bad("IMU rate must be positive");
  if (rec.imu.empty()) return bad("no IMU samples");
  if (rec.table_kind == calib::TableKind::kThreeAxis && rec.outer_axis_heading_deg) {
    return bad("outer_axis_heading_deg applies to two-axis tables only");
  }
  for (size_t i = 0; i < rec.imu.size(); ++i) {
    const auto& s = rec.imu[i];
    if (!std::isfinite(s.t) || !s.dtheta.allFinite() || !s.dvel.allFinite() ||
        std::isinf(s.temp_c)) {
      return bad("IMU sample " + std::to_string(i) + " has a non-finite value");
    }
    if (i > 0 && !(s.t > rec.imu[i - 1].t))
      return bad("IMU sample " + std::to_string(i) + " time does not increase");
  }
  const int n = calib::axisCount(rec.table_kind);
  for (size_t i = 0; i < rec.table.size(); ++i) {
    const auto& s = rec.table[i];
    bool finite = std::isfinite(s.t);
    for (int a = 0; a < n; ++a)
      finite = finite && std::isfinite(s.angles_deg[static_cast<size_t>(a)]);
    if (!finite) return bad("table sample " + std::to_string(i) + " has a non-finite value");
    if (i > 0 && !(s.t > rec.table[i - 1].t))
      return bad("table sample " + std::to_string(i) + " time does not increase");
  }
  for (size_t i = 0; i < rec.chamber.size(); ++i) {
    const auto& s = rec.chamber[i];
    if (!std::isfinite(s.t) || !std::isfinite(s.setpoint_c) || !std::isfinite(s.temp_c)) {
      return bad("chamber sample " + std::to_string(i) + " has a non-finite value");
    }
    if (i > 0 && !(s.t > rec.chamber[i - 1].t))
      return bad("chamber sample " + std::to_string(i) + " time does not increase");
  }
  for (size_t i = 0; i < rec.segments.size(); ++i) {
    const auto& s = rec.segments[i];
    if (!std::isfinite(s.t0) || !std::isfinite(s.t1) || !(s.t1 > s.t0))
      return bad("segment " + std::to_string(i) + " has a bad time span");
    if (i > 0 && s.t0 < rec.segments[i - 1].t1)
      return bad("segment " + std::to_string(i) + " overlaps the previous one");
    if (s.label.find_first_of("\n\r") != std::string::npos)
      return bad("segment " + std::to_string(i) + " label contains a line break");
  }
  return Status::Ok();
}

}  // namespace

nav::Site Recording::site() const {
  nav::Site s;
  s.latitude_rad = latitude_deg * kDegToRad;
  s.height_m = height_m;
  s.gravity_mps2 = gravity_mps2;
  return s;
}

std::vector<double> tableAnglesRad(calib::TableKind kind, const TableSample& s) {
  std::vector<double> r(static_cast<size_t>(calib::axisCount(kind)));
  for (size_t a = 0; a < r.size(); ++a) r[a] = s.angles_deg[a] * kDegToRad;
  return r;
}

Status writeRecording(const std::string& dir, const Recording& rec) {
  if (auto st = validateForWrite(rec); !st.ok) return st;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Status::Error(dir + ": cannot create directory: " + ec.message());
  const fs::path d(dir);

  // meta.json
  {
    nlohmann::ordered_json meta;
    meta["format"] = kRecordingFormat;
    meta["site"]["latitude_deg"] = rec.latitude_deg;
    meta["site"]["height_m"] = rec.height_m;
    if (rec.gravity_mps2) meta["site"]["gravity_mps2"] = *rec.gravity_mps2;
    meta["imu"]["serial"] = rec.imu_serial;
    meta["imu"]["rate_hz"] = rec.imu_rate_hz;
    meta["table"]["kind"] =
        rec.table_kind == calib::TableKind::kTwoAxis ? "two-axis" : "three-axis";
    if (rec.outer_axis_heading_deg)
      meta["table"]["outer_axis_heading_deg"] = *rec.outer_axis_heading_deg;
    const std::string text = meta.dump(2) + "\n";
    auto st = writeFile((d / "meta.json").string(), [&](CsvWriter& w) { w.text(text); });
    if (!st.ok) return st;
  }
  // imu.csv
  auto st = writeTable(d / "imu.csv", kImuHeader, rec.imu, [](CsvWriter& w, const auto& s) {
    w.number(s.t);
    for (int i = 0; i < 3; ++i) {
      w.comma();
      w.number(s.dtheta[i]);
    }
    for (int i = 0; i < 3; ++i) {
      w.comma();
      w.number(s.dvel[i]);
    }
    w.comma();
    if (!std::isnan(s.temp_c)) w.number(s.temp_c);
  });
  if (!st.ok) return st;
  // table.csv
  const int n_axes = calib::axisCount(rec.table_kind);
  st = writeTable(d / "table.csv", n_axes == 2 ? kTable2Header : kTable3Header, rec.table,
                  [&](CsvWriter& w, const auto& s) {
                    w.number(s.t);
                    for (int a = 0; a < n_axes; ++a) {
                      w.comma();
                      w.number(s.angles_deg[static_cast<size_t>(a)]);
                    }
                  });
  if (!st.ok) return st;
  // chamber.csv, segments.csv: optional.
  st = writeOptionalTable(d / "chamber.csv", kChamberHeader, rec.chamber,
                          [](CsvWriter& w, const auto& s) {
                            w.number(s.t);
                            w.comma();
                            w.number(s.setpoint_c);
                            w.comma();
                            w.number(s.temp_c);
                          });
  if (!st.ok) return st;
  return writeOptionalTable(d / "segments.csv", kSegmentsHeader, rec.segments,
                            [](CsvWriter& w, const auto& s) {
                              w.number(s.t0);
                              w.comma();
                              w.number(s.t1);
                              w.comma();
                              w.text(calib::segmentKindName(s.kind));
                              w.comma();
                              w.text(quoteLabel(s.label));
                            });
}

RecordingReadResult readRecording(const std::string& dir) {
  RecordingReadResult result;
  Recording& rec = result.value;
  const fs::path d(dir);
  auto fail = [&](Status st) {
    result.status = std::move(st);
    result.value = Recording{};
    return result;
  };
  std::error_code ec;
  if (!fs::is_directory(d, ec)) return fail(Status::Error(dir + ": not a directory"));

  std::string text;
  const std::string meta_path = (d / "meta.json").string();
  if (auto st = readWholeFile(meta_path, &text); !st.ok) return fail(st);
  if (auto st = readMeta(meta_path, text, &rec); !st.ok) return fail(st);

  // imu.csv
  const std::string imu_path = (d / "imu.csv").string();
  if (auto st = readImuCsv(imu_path, &rec.imu); !st.ok) return fail(st);
  if (rec.imu.empty()) return fail(Status::Error(at(imu_path, 2, "no samples after the header")));
  // table.csv
  const std::string table_path = (d / "table.csv").string();
  {
    const bool two = rec.table_kind == calib::TableKind::kTwoAxis;
    const std::string_view header = two ? kTable2Header : kTable3Header;
    const std::string note = two ? " (meta.json says two-axis)" : " (meta.json says three-axis)";
    const int n_axes = calib::axisCount(rec.table_kind);
    auto st = readNumericCsv(
        table_path, header, note, -1, [&](size_t rows) { rec.table.reserve(rows); },
        [&](const double* v) {
          TableSample s;
          s.t = v[0];
          for (int a = 0; a < n_axes; ++a) s.angles_deg[static_cast<size_t>(a)] = v[a + 1];
          rec.table.push_back(s);
        });
    if (!st.ok) return fail(st);
    // A header without rows: a recording without table angles (a logger's file imported by
    // `imubench import-csv`, docs/import.md); no segments are derived from it.
  }
  // chamber.csv (optional)
  const std::string chamber_path = (d / "chamber.csv").string();
  if (fs::exists(chamber_path, ec)) {
    auto st = readNumericCsv(
        chamber_path, kChamberHeader, "", -1, [&](size_t rows) { rec.chamber.reserve(rows); },
        [&](const double* v) {
          rec.chamber.push_back({v[0], v[1], v[2]});
        });
    if (!st.ok) return fail(st);
  }
  // segments.csv (optional)
  const std::string seg_path = (d / "segments.csv").string();
  if (fs::exists(seg_path, ec)) {
    if (auto st = readWholeFile(seg_path, &text); !st.ok) return fail(st);
    if (auto st = readSegments(seg_path, text, &rec.segments); !st.ok) return fail(st);
    rec.segments_from_file = true;
    fillRotateAxes(rec.table, rec.table_kind, &rec.segments);
  } else {
    rec.segments = deriveSegments(rec.table_kind, rec.table);
    rec.segments_from_file = false;
  }
  result.status = Status::Ok();
  return result;
}

// ---------------------------------------------------------------------------------------
// Segment derivation

bool SegmentDerivationOptions::IsValid(std::string* why) const {
  if (!(still_rate_deg_s > 0.0) || !std::isfinite(still_rate_deg_s)) {
    if (why) *why = "still_rate_deg_s must be positive";
    return false;
  }
  if (!(min_static_s >= 0.0) || !std::isfinite(min_static_s)) {
    if (why) *why = "min_static_s must be non-negative";
    return false;
  }
  return true;
}

namespace {
// Encoder step between two readings, unwrapped to (-180, 180] deg.
double unwrappedStepDeg(double a0, double a1) {
  double d = a1 - a0;
  while (d > 180.0) d -= 360.0;
  while (d <= -180.0) d += 360.0;
  return d;
}
}  // namespace

double netAxisAngle(const std::vector<TableSample>& table, int axis, double t0, double t1) {
  const auto cmp = [](const TableSample& s, double t) { return s.t < t; };
  auto it = std::lower_bound(table.begin(), table.end(), t0, cmp);
  double sum = 0.0;
  const size_t a = static_cast<size_t>(axis);
  for (; it != table.end() && std::next(it) != table.end() && std::next(it)->t <= t1; ++it) {
    sum += unwrappedStepDeg(it->angles_deg[a], std::next(it)->angles_deg[a]);
  }
  return sum * kDegToRad;
}

std::vector<calib::Segment> deriveSegments(calib::TableKind kind,
                                           const std::vector<TableSample>& table,
                                           const SegmentDerivationOptions& options) {
  std::vector<calib::Segment> out;
  if (table.size() < 2) return out;
  const int n_axes = calib::axisCount(kind);
  const size_t n_int = table.size() - 1;
  // Per interval: bitmask of moving axes.
  std::vector<unsigned> moving(n_int, 0u);
  for (size_t i = 0; i < n_int; ++i) {
    const double dt = table[i + 1].t - table[i].t;
    for (int a = 0; a < n_axes; ++a) {
      const size_t ax = static_cast<size_t>(a);
      const double rate =
          unwrappedStepDeg(table[i].angles_deg[ax], table[i + 1].angles_deg[ax]) / dt;
      if (std::abs(rate) >= options.still_rate_deg_s) moving[i] |= 1u << a;
    }
  }
  // Spans: runs of still intervals long enough are static; everything else is motion.
  struct Span {
    size_t i0, i1;  // interval index range [i0, i1)
    bool still;
  };
  std::vector<Span> spans;
  size_t i = 0;
  while (i < n_int) {
    size_t j = i;
    const bool still = moving[i] == 0u;
    while (j < n_int && (moving[j] == 0u) == still) ++j;
    const double dur = table[j].t - table[i].t;
    const bool is_static = still && dur >= options.min_static_s;
    if (!spans.empty() && !spans.back().still && !is_static) {
      spans.back().i1 = j;  // merge short pauses and motion into the running motion span
    } else {
      spans.push_back({i, j, is_static});
    }
    i = j;
  }
  int n_static = 0, n_rotate = 0, n_move = 0;
  for (const auto& sp : spans) {
    calib::Segment seg;
    seg.t0 = table[sp.i0].t;
    seg.t1 = table[sp.i1].t;
    unsigned mask = 0u;
    for (size_t k = sp.i0; k < sp.i1; ++k) mask |= moving[k];
    if (sp.still || mask == 0u) {
      seg.kind = calib::SegmentKind::kStatic;
      seg.label = "static-" + std::to_string(++n_static);
    } else if ((mask & (mask - 1u)) == 0u) {
      seg.kind = calib::SegmentKind::kRotate;
      seg.axis = std::countr_zero(mask);
      seg.angle = netAxisAngle(table, seg.axis, seg.t0, seg.t1);
      seg.label = "rotate-" + std::to_string(++n_rotate);
    } else {
      seg.kind = calib::SegmentKind::kMove;
      seg.label = "move-" + std::to_string(++n_move);
    }
    // Merge consecutive static spans (a motion span without motion became static).
    if (!out.empty() && out.back().kind == calib::SegmentKind::kStatic &&
        seg.kind == calib::SegmentKind::kStatic) {
      out.back().t1 = seg.t1;
      --n_static;
      continue;
    }
    out.push_back(std::move(seg));
  }
  return out;
}

}  // namespace imubench::io
