#include "io/logger_csv.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "io/csv_text.h"
#include "io/file_io.h"

namespace imubench::io {
namespace {

constexpr double kStandardGravity = 9.80665;  // m/s^2, the definition of the unit g
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// ---- units ----------------------------------------------------------------------------

bool physicalUnit(char q, const std::string& u, double* factor, bool* increment) {
  static const std::map<std::string, std::pair<double, bool>> w = {{"rad/s", {1.0, false}},
                                                                   {"deg/s", {kDeg, false}},
                                                                   {"rad", {1.0, true}},
                                                                   {"deg", {kDeg, true}}};
  static const std::map<std::string, std::pair<double, bool>> a = {{"m/s^2", {1.0, false}},
                                                                   {"m/s2", {1.0, false}},
                                                                   {"g", {kStandardGravity, false}},
                                                                   {"m/s", {1.0, true}}};
  static const std::map<std::string, std::pair<double, bool>> t = {
      {"s", {1.0, false}}, {"ms", {1e-3, false}}, {"us", {1e-6, false}}, {"ns", {1e-9, false}}};
  const auto& m = q == 'w' ? w : q == 'a' ? a : t;
  const auto it = m.find(u);
  if (it == m.end()) return false;
  *factor = it->second.first;
  *increment = it->second.second;
  return true;
}

const char* unitChoices(char q) {
  if (q == 'w') return "rad/s, deg/s, rad, deg (increments), count:K:U or lsb:N:U";
  if (q == 'a') return "m/s^2, g, m/s (increments), count:K:U or lsb:N:U";
  return "s, ms, us, ns";
}

}  // namespace

bool parseColumnUnit(char q, const std::string& text, ColumnUnit* unit, std::string* why) {
  unit->text = text;
  const std::size_t c1 = text.find(':');
  const std::string kind = text.substr(0, c1);
  if ((kind == "count" || kind == "lsb") && q != 't' && c1 != std::string::npos) {
    const std::size_t c2 = text.find(':', c1 + 1);
    double k = 0.0;
    std::string e;
    if (c2 == std::string::npos ||
        !parseNumber(std::string_view(text).substr(c1 + 1, c2 - c1 - 1), kind, &k, &e) ||
        !(k > 0.0) || !physicalUnit(q, text.substr(c2 + 1), &unit->factor, &unit->increment)) {
      *why = "unit '" + text + "': expected " + kind + ":" + (kind == "count" ? "K" : "N") +
             ":U with a positive number and U one of " + unitChoices(q);
      return false;
    }
    unit->factor = kind == "count" ? unit->factor * k : unit->factor / k;
    return true;
  }
  if (!physicalUnit(q, text, &unit->factor, &unit->increment)) {
    *why = "unit '" + text + "' unknown; expected " + unitChoices(q);
    return false;
  }
  return true;
}

namespace {

// ---- splitting and layout ---------------------------------------------------------------

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return s;
}

// Fields of a line: delimiter ' ' splits on runs of blanks (leading/trailing ignored).
void splitLine(std::string_view line, char delim, std::vector<std::string_view>* out) {
  out->clear();
  if (delim == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i == line.size()) break;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      out->push_back(line.substr(i, j - i));
      i = j;
    }
    return;
  }
  std::size_t s = 0;
  for (;;) {
    const std::size_t c = line.find(delim, s);
    out->push_back(trim(line.substr(s, c == std::string_view::npos ? c : c - s)));
    if (c == std::string_view::npos) break;
    s = c + 1;
  }
}

bool blankOrComment(std::string_view line) {
  const std::string_view t = trim(line);
  return t.empty() || t.front() == '#';
}

bool isNumber(std::string_view f) {
  double v = 0.0;
  std::string why;
  return parseNumber(f, "", &v, &why) || f == "nan" || f == "NaN" || f == "NAN";
}

std::string delimiterName(char d) {
  if (d == '\t') return "tab";
  if (d == ' ') return "whitespace";
  return std::string("'") + d + "'";
}

// The delimiter whose most frequent field count (>= 2) holds on at least 80 % of the first
// lines (a truncated row among them is a bad row, not a reason to guess another delimiter),
// preferring , tab ; | and whitespace in that order.
bool detectDelimiter(const std::vector<std::string_view>& first, char* delim) {
  std::vector<std::string_view> f;
  for (char d : {',', '\t', ';', '|', ' '}) {
    std::map<std::size_t, std::size_t> counts;
    for (std::string_view line : first) {
      splitLine(line, d, &f);
      ++counts[f.size()];
    }
    const auto mode =
        std::max_element(counts.begin(), counts.end(),
                         [](const auto& a, const auto& b) { return a.second < b.second; });
    if (mode->first >= 2 && 5 * mode->second >= 4 * first.size()) {
      *delim = d;
      return true;
    }
  }
  return false;
}

// Detects (or takes) the delimiter and header from the first non-blank lines of `text`.
Status detectLayout(std::string_view text, const LoggerImportOptions& o, FileLayout* lay) {
  LineCursor cur(text);
  std::string_view line;
  std::vector<std::string_view> first;
  while (first.size() < 20 && cur.next(&line))
    if (!blankOrComment(line)) first.push_back(line);
  if (first.empty()) return Status::Error(lay->path + ": no data rows");
  if (o.delimiter) {
    lay->delimiter = *o.delimiter;
  } else if (!detectDelimiter(first, &lay->delimiter)) {
    return Status::Error(lay->path +
                         ": cannot detect the delimiter (no one of , tab ; | whitespace splits the "
                         "first rows into the same number of fields); give --delimiter");
  }
  std::vector<std::string_view> f;
  splitLine(first[0], lay->delimiter, &f);
  bool numeric = true;
  for (std::string_view x : f) numeric = numeric && isNumber(x);
  lay->header = o.header.value_or(!numeric);
  if (lay->header)
    for (std::string_view x : f) lay->names.emplace_back(x);
  return Status::Ok();
}

// Index (0-based) of a column by header name (exact, else case-insensitive and unique) or by
// 1-based index.
bool resolveColumn(const FileLayout& lay, std::size_t n_fields, const std::string& key,
                   const ColumnRef& ref, std::size_t* index, std::string* why) {
  const std::string& s = ref.text;
  if (!s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    const std::size_t k = std::stoul(s);
    if (k >= 1 && k <= n_fields) {
      *index = k - 1;
      return true;
    }
    *why = "column " + key + "=" + s + ": the file has " + std::to_string(n_fields) + " columns";
    return false;
  }
  std::vector<std::size_t> hits;
  for (std::size_t i = 0; i < lay.names.size(); ++i)
    if (lay.names[i] == s) hits.push_back(i);
  for (std::size_t i = 0; hits.empty() && i < lay.names.size(); ++i) {
    const std::string& n = lay.names[i];
    if (n.size() == s.size() && std::equal(n.begin(), n.end(), s.begin(), [](char a, char b) {
          return std::tolower(static_cast<unsigned char>(a)) ==
                 std::tolower(static_cast<unsigned char>(b));
        }))
      hits.push_back(i);
  }
  if (hits.size() == 1) {
    *index = hits[0];
    return true;
  }
  std::string names;
  for (const auto& n : lay.names) names += (names.empty() ? "" : ", ") + n;
  *why = "column " + key + "=" + s +
         (lay.names.empty() ? ": the file has no header; name columns by 1-based index"
          : hits.empty()    ? " not in the header (" + names + ")"
                            : " is ambiguous in the header (" + names + ")");
  return false;
}

// ---- one file -------------------------------------------------------------------------

struct ParsedRow {
  long line = 0;
  long data_index = 0;  // k-th data row of the file (from 0), for --rate times
  std::vector<double> v;
};

struct ParsedFile {
  FileLayout layout;
  std::vector<ParsedRow> rows;  // the good rows
};

struct Wanted {
  std::vector<std::string> keys;  // e.g. t, ax, ay, az, temp
  std::vector<ColumnRef> refs;
};

// Parses one data line into the wanted columns; false with *why (wrong count, not a number).
bool parseRow(const std::vector<std::string_view>& f, std::size_t n_fields,
              const std::vector<std::size_t>& idx, const Wanted& w, std::vector<double>* v,
              std::string* why) {
  if (f.size() != n_fields) {
    *why = "expected " + std::to_string(n_fields) + " columns, found " + std::to_string(f.size());
    return false;
  }
  v->resize(idx.size());
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const std::string_view x = f[idx[k]];
    const std::string col = w.keys[k] + " (" + w.refs[k].text + ")";
    if (w.keys[k] == "temp" && x.empty()) {
      (*v)[k] = std::nan("");
      continue;
    }
    if (x == "nan" || x == "NaN" || x == "NAN" || x == "-nan") {
      *why = "column " + col + " is NaN";
      return false;
    }
    if (!parseNumber(x, col, &(*v)[k], why)) return false;
  }
  return true;
}

Status readLoggerFile(const std::string& path, const LoggerImportOptions& o, const Wanted& w,
                      ParsedFile* out, std::vector<BadRow>* bad) {
  std::string text;
  if (Status st = readWholeFile(path, &text); !st.ok) return st;
  if (text.size() >= 3 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);  // BOM
  out->layout.path = path;
  if (Status st = detectLayout(text, o, &out->layout); !st.ok) return st;
  FileLayout& lay = out->layout;
  LineCursor cur(text);
  std::string_view line;
  std::vector<std::string_view> f;
  std::size_t n_fields = 0;
  std::vector<std::size_t> idx(w.keys.size());
  bool header_seen = !lay.header;
  for (;;) {
    if (!cur.next(&line)) break;
    if (blankOrComment(line)) {
      ++lay.skipped_lines;
      continue;
    }
    splitLine(line, lay.delimiter, &f);
    if (n_fields == 0) {
      n_fields = f.size();
      std::string why;
      for (std::size_t k = 0; k < w.keys.size(); ++k)
        if (!resolveColumn(lay, n_fields, w.keys[k], w.refs[k], &idx[k], &why))
          return Status::Error(path + ": " + why);
    }
    if (!header_seen) {
      header_seen = true;
      continue;
    }
    ParsedRow row{cur.lineNo(), lay.data_rows++, {}};
    std::string why;
    if (!parseRow(f, n_fields, idx, w, &row.v, &why)) {
      bad->push_back({path, row.line, why});
      continue;
    }
    out->rows.push_back(std::move(row));
  }
  if (lay.data_rows == 0) return Status::Error(path + ": no data rows");
  return Status::Ok();
}

// ---- time -----------------------------------------------------------------------------

// A row of the accelerometer file (o.path) with its gyro partner, in SI.
struct TimedRow {
  long line = 0;
  long gyro_line = 0;  // two files: the gyro file's row
  double t = 0.0;
  Vec3 w = Vec3::Zero(), a = Vec3::Zero();
  double temp = std::nan("");
};

// Times of a file's rows in s: the "t" column (first wanted) or data_index / rate. Rows whose
// time does not increase over the previous good row are bad.
std::vector<double> rowTimes(ParsedFile* pf, const LoggerImportOptions& o, double unit,
                             std::vector<BadRow>* bad) {
  std::vector<double> t;
  std::vector<ParsedRow> kept;
  for (ParsedRow& r : pf->rows) {
    const double ti = o.rate_hz ? static_cast<double>(r.data_index) / *o.rate_hz : r.v[0] * unit;
    if (!t.empty() && !(ti > t.back())) {
      bad->push_back({pf->layout.path, r.line,
                      "time " + fmtDouble(ti) + " s is not after the previous row's " +
                          fmtDouble(t.back()) + " s"});
      continue;
    }
    t.push_back(ti);
    kept.push_back(std::move(r));
  }
  pf->rows = std::move(kept);
  return t;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double medianInterval(const std::vector<double>& t) {
  std::vector<double> dt;
  for (std::size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
  return median(dt);
}

// Pairs the gyro file's rows with the accelerometer file's: the same data row with --rate,
// else the nearest stamp within match_fraction of the median interval. Unpaired rows of
// either file are bad.
std::vector<std::pair<std::size_t, std::size_t>> pairRows(
    const ParsedFile& fa, const std::vector<double>& ta, const ParsedFile& fg,
    const std::vector<double>& tg, const LoggerImportOptions& o, std::vector<BadRow>* bad) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  const double tol = o.match_fraction * medianInterval(ta);
  std::vector<bool> used(tg.size(), false);
  std::size_t j = 0;
  for (std::size_t i = 0; i < ta.size(); ++i) {
    if (o.rate_hz) {
      while (j < tg.size() && fg.rows[j].data_index < fa.rows[i].data_index) ++j;
      if (j < tg.size() && fg.rows[j].data_index == fa.rows[i].data_index) {
        pairs.emplace_back(i, j);
        used[j] = true;
        continue;
      }
    } else {
      while (j + 1 < tg.size() && tg[j + 1] <= ta[i]) ++j;
      std::size_t best = j;
      if (j + 1 < tg.size() && std::abs(tg[j + 1] - ta[i]) < std::abs(tg[j] - ta[i])) best = j + 1;
      if (best < tg.size() && !used[best] && std::abs(tg[best] - ta[i]) <= tol) {
        pairs.emplace_back(i, best);
        used[best] = true;
        continue;
      }
    }
    bad->push_back({fa.layout.path, fa.rows[i].line,
                    "no row of " + fg.layout.path + " at time " + fmtDouble(ta[i]) + " s"});
  }
  for (std::size_t k = 0; k < tg.size(); ++k)
    if (!used[k])
      bad->push_back({fg.layout.path, fg.rows[k].line,
                      "no row of " + fa.layout.path + " at time " + fmtDouble(tg[k]) + " s"});
  return pairs;
}

// ---- checks, timing, increments ---------------------------------------------------------

// Implausible static specific force: a row inside a still, steady window (every gyro rate
// below static_rate_radps, |f| varying by less than 0.1 g over about 0.2 s around it) whose
// mean |f| differs from gravity by more than static_force_tolerance g. A shock or a turn is
// not static and is never judged; a unit error flags every still window.
void staticCheck(const std::vector<TimedRow>& rows, const std::vector<double>& dt,
                 const LoggerImportOptions& o, std::vector<bool>* keep, std::vector<BadRow>* bad) {
  if (!(o.static_force_tolerance > 0.0) || rows.size() < 3) return;
  const double g = o.gravity_mps2.value_or(kStandardGravity);
  const std::size_t n = rows.size();
  std::vector<double> wn(n), fn(n);
  for (std::size_t i = 0; i < n; ++i) {
    wn[i] = rows[i].w.norm() / (o.gyro_unit.increment ? dt[i] : 1.0);
    fn[i] = rows[i].a.norm() / (o.accel_unit.increment ? dt[i] : 1.0);
  }
  std::vector<double> sorted(dt);
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(n / 2), sorted.end());
  const std::size_t half = std::max<std::size_t>(2, static_cast<std::size_t>(0.1 / sorted[n / 2]));
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i > half ? i - half : 0, b = std::min(n, i + half + 1);
    double wmax = 0.0, flo = fn[a], fhi = fn[a], fsum = 0.0;
    for (std::size_t k = a; k < b; ++k) {
      wmax = std::max(wmax, wn[k]);
      flo = std::min(flo, fn[k]);
      fhi = std::max(fhi, fn[k]);
      fsum += fn[k];
    }
    const double fmean = fsum / static_cast<double>(b - a);
    if (wmax >= o.static_rate_radps || fhi - flo > 0.1 * g * std::max(1.0, fmean / g) ||
        std::abs(fmean - g) <= o.static_force_tolerance * g)
      continue;
    char buf[220];
    std::snprintf(buf, sizeof buf,
                  "implausible static specific force: |f| = %.4g m/s^2 (%.3g g) while the IMU is "
                  "still (gyro below %.3g rad/s); check the accelerometer unit (--units a=...)",
                  fn[i], fn[i] / g, o.static_rate_radps);
    bad->push_back({o.path, rows[i].line, buf});
    (*keep)[i] = false;
  }
}

TimingReport measureTiming(const std::vector<TimedRow>& rows, const std::string& path,
                           bool from_rate) {
  TimingReport r;
  r.from_rate = from_rate;
  std::vector<double> t;
  for (const TimedRow& x : rows) t.push_back(x.t);
  r.median_dt_s = medianInterval(t);
  if (!(r.median_dt_s > 0.0)) return r;
  r.rate_hz = 1.0 / r.median_dt_s;
  double ss = 0.0;
  std::size_t n = 0;
  r.min_dt_s = r.max_dt_s = t.size() > 1 ? t[1] - t[0] : 0.0;
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double dt = t[i] - t[i - 1];
    r.min_dt_s = std::min(r.min_dt_s, dt);
    r.max_dt_s = std::max(r.max_dt_s, dt);
    if (dt > 1.5 * r.median_dt_s) {
      r.gaps.push_back({path, rows[i].line, t[i - 1], t[i]});
      continue;
    }
    ss += (dt - r.median_dt_s) * (dt - r.median_dt_s);
    r.jitter_max_s = std::max(r.jitter_max_s, std::abs(dt - r.median_dt_s));
    ++n;
  }
  r.jitter_rms_s = n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
  return r;
}

// Increments over (t_{k-1}, t_k]; the first row's interval is the median interval.
nav::ImuSamples toIncrements(const std::vector<TimedRow>& rows, const LoggerImportOptions& o,
                             double median_dt) {
  nav::ImuSamples out;
  out.reserve(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double dt = i == 0 ? median_dt : rows[i].t - rows[i - 1].t;
    nav::ImuSample s;
    s.t = rows[i].t;
    s.dtheta = o.gyro_unit.increment ? rows[i].w : Vec3(rows[i].w * dt);
    s.dvel = o.accel_unit.increment ? rows[i].a : Vec3(rows[i].a * dt);
    s.temp_c = rows[i].temp;
    out.push_back(s);
  }
  return out;
}

// Area-preserving resampling: cumulative increments interpolated linearly at the new interval
// ends (t0 + k / hz), differenced; temperature interpolated.
nav::ImuSamples resample(const nav::ImuSamples& in, double first_start, double hz) {
  std::vector<double> tc{first_start};
  std::vector<Vec3> th{Vec3::Zero()}, v{Vec3::Zero()};
  for (const nav::ImuSample& s : in) {
    tc.push_back(s.t);
    th.push_back(th.back() + s.dtheta);
    v.push_back(v.back() + s.dvel);
  }
  nav::ImuSamples out;
  std::size_t j = 0;
  Vec3 th_prev = Vec3::Zero(), v_prev = Vec3::Zero();
  for (long k = 1;; ++k) {
    const double t = first_start + static_cast<double>(k) / hz;
    if (t > tc.back()) break;
    while (j + 2 < tc.size() && tc[j + 1] < t) ++j;
    const double u = (t - tc[j]) / (tc[j + 1] - tc[j]);
    const Vec3 th_t = th[j] + u * (th[j + 1] - th[j]);
    const Vec3 v_t = v[j] + u * (v[j + 1] - v[j]);
    nav::ImuSample s;
    s.t = t;
    s.dtheta = th_t - th_prev;
    s.dvel = v_t - v_prev;
    const nav::ImuSample& a = in[j == 0 ? 0 : j - 1];
    const nav::ImuSample& b = in[j];
    s.temp_c = j == 0 ? b.temp_c : a.temp_c + (t - a.t) / (b.t - a.t) * (b.temp_c - a.temp_c);
    th_prev = th_t;
    v_prev = v_t;
    out.push_back(s);
  }
  return out;
}

// ---- assembling ---------------------------------------------------------------------------

std::string columnOf(const LoggerImportOptions& o, const std::string& key) {
  for (const auto& [k, ref] : o.columns)
    if (k == key) return ref.text;
  return "";
}

// The wanted columns of the accelerometer file (and of the gyro file when given).
Status wantedColumns(const LoggerImportOptions& o, Wanted* wa, Wanted* wg) {
  const bool two = !o.gyro_path.empty();
  auto add = [&](Wanted* w, const std::string& key, const std::string& as, bool required) {
    const std::string c = columnOf(o, key);
    if (c.empty()) return !required;
    w->keys.push_back(as);
    w->refs.push_back({c});
    return true;
  };
  for (const auto& [k, ref] : o.columns) {
    static const std::vector<std::string> known = {"t",  "gt", "wx", "wy",  "wz",
                                                   "ax", "ay", "az", "temp"};
    if (std::find(known.begin(), known.end(), k) == known.end())
      return Status::Error("--columns: unknown key '" + k +
                           "' (t, wx, wy, wz, ax, ay, az, temp, gt)");
  }
  if (!o.rate_hz) {
    if (!add(wa, "t", "t", true)) return Status::Error("--columns needs t=COL (or give --rate HZ)");
    if (two) add(wg, columnOf(o, "gt").empty() ? "t" : "gt", "t", true);
  } else if (!columnOf(o, "t").empty()) {
    return Status::Error("give either a time column (t=...) or --rate, not both");
  }
  for (const char* k : {"ax", "ay", "az"})
    if (!add(wa, k, k, true)) return Status::Error(std::string("--columns needs ") + k + "=COL");
  for (const char* k : {"wx", "wy", "wz"})
    if (!add(two ? wg : wa, k, k, true))
      return Status::Error(std::string("--columns needs ") + k + "=COL");
  add(wa, "temp", "temp", false);
  return Status::Ok();
}

std::size_t keyIndex(const Wanted& w, const std::string& key) {
  return static_cast<std::size_t>(std::find(w.keys.begin(), w.keys.end(), key) - w.keys.begin());
}

Vec3 triadOf(const ParsedRow& r, const Wanted& w, const char* x, double factor) {
  return Vec3(r.v[keyIndex(w, std::string(x) + "x")], r.v[keyIndex(w, std::string(x) + "y")],
              r.v[keyIndex(w, std::string(x) + "z")]) *
         factor;
}

// The files read, paired and converted to SI: rows in time order (bad rows appended to *bad).
Status timedRows(const LoggerImportOptions& o, LoggerImport* r, std::vector<TimedRow>* rows) {
  Wanted wa, wg;
  if (Status st = wantedColumns(o, &wa, &wg); !st.ok) return st;
  ParsedFile fa, fg;
  if (Status st = readLoggerFile(o.path, o, wa, &fa, &r->bad_rows); !st.ok) return st;
  const bool two = !o.gyro_path.empty();
  if (two) {
    if (Status st = readLoggerFile(o.gyro_path, o, wg, &fg, &r->bad_rows); !st.ok) return st;
  }
  const std::vector<double> ta = rowTimes(&fa, o, o.time_unit.factor, &r->bad_rows);
  const std::vector<double> tg =
      two ? rowTimes(&fg, o, o.time_unit.factor, &r->bad_rows) : std::vector<double>{};
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  if (two) {
    pairs = pairRows(fa, ta, fg, tg, o, &r->bad_rows);
  } else {
    for (std::size_t i = 0; i < ta.size(); ++i) pairs.emplace_back(i, i);
  }
  const std::size_t ti = keyIndex(wa, "temp");
  for (const auto& [i, j] : pairs) {
    TimedRow x;
    x.line = fa.rows[i].line;
    x.t = ta[i];
    x.a = triadOf(fa.rows[i], wa, "a", o.accel_unit.factor);
    x.w = two ? triadOf(fg.rows[j], wg, "w", o.gyro_unit.factor)
              : triadOf(fa.rows[i], wa, "w", o.gyro_unit.factor);
    x.gyro_line = two ? fg.rows[j].line : x.line;
    if (ti < wa.keys.size()) x.temp = fa.rows[i].v[ti];
    rows->push_back(x);
  }
  r->files.push_back(fa.layout);
  if (two) r->files.push_back(fg.layout);
  return Status::Ok();
}

Status checkOptions(const LoggerImportOptions& o) {
  if (o.rate_hz && !(*o.rate_hz > 0.0)) return Status::Error("--rate must be > 0");
  if (o.resample_hz && !(*o.resample_hz > 0.0)) return Status::Error("--resample must be > 0");
  if (o.gravity_mps2 && !(*o.gravity_mps2 > 5.0 && *o.gravity_mps2 < 15.0))
    return Status::Error("--gravity must be a local gravity in m/s^2 (5..15)");
  if (!(o.latitude_deg >= -90.0 && o.latitude_deg <= 90.0))
    return Status::Error("--latitude outside [-90, 90]");
  if (!(o.match_fraction > 0.0 && o.match_fraction < 0.5))
    return Status::Error("match fraction must be in (0, 0.5)");
  return Status::Ok();
}

}  // namespace

LoggerImport importLogger(const LoggerImportOptions& o) {
  LoggerImport r;
  if (Status st = checkOptions(o); !st.ok) return r.status = st, r;
  std::vector<TimedRow> rows;
  if (Status st = timedRows(o, &r, &rows); !st.ok) return r.status = st, r;
  const double median_dt = medianInterval([&] {
    std::vector<double> t;
    for (const TimedRow& x : rows) t.push_back(x.t);
    return t;
  }());
  std::vector<double> dt(rows.size(), median_dt);
  for (std::size_t i = 1; i < rows.size(); ++i) dt[i] = rows[i].t - rows[i - 1].t;
  std::vector<bool> keep(rows.size(), true);
  staticCheck(rows, dt, o, &keep, &r.bad_rows);
  std::sort(r.bad_rows.begin(), r.bad_rows.end(), [](const BadRow& a, const BadRow& b) {
    return a.file != b.file ? a.file < b.file : a.line < b.line;
  });
  if (!r.bad_rows.empty() && !o.skip_bad_rows) {
    r.status =
        Status::Error(std::to_string(r.bad_rows.size()) + " bad row" +
                      (r.bad_rows.size() > 1 ? "s" : "") + ", the first " + r.bad_rows[0].where() +
                      ": " + r.bad_rows[0].why + " (--skip-bad-rows leaves them out, each listed)");
    return r;
  }
  std::vector<TimedRow> kept;
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (keep[i]) kept.push_back(rows[i]);
  if (kept.size() < 2) return r.status = Status::Error(o.path + ": fewer than two good rows"), r;
  r.timing = measureTiming(kept, o.path, o.rate_hz.has_value());
  nav::ImuSamples imu = toIncrements(kept, o, r.timing.median_dt_s);
  double rate = r.timing.rate_hz;
  if (o.resample_hz) {
    imu = resample(imu, kept[0].t - r.timing.median_dt_s, *o.resample_hz);
    rate = *o.resample_hz;
    r.notes.push_back("resampled to " + fmtDouble(rate) +
                      " Hz (cumulative increments interpolated, area preserved)");
  }
  Recording& rec = r.recording;
  rec.imu = std::move(imu);
  rec.imu_rate_hz = rate;
  rec.latitude_deg = o.latitude_deg;
  rec.height_m = o.height_m;
  rec.gravity_mps2 = o.gravity_mps2;
  rec.imu_serial = o.serial;
  r.status = Status::Ok();
  return r;
}

std::string importReportJson(const LoggerImportOptions& o, const LoggerImport& r) {
  nlohmann::ordered_json j;
  j["format"] = "imubench-import/1";
  for (const FileLayout& f : r.files) {
    j["files"].push_back({{"path", f.path},
                          {"delimiter", delimiterName(f.delimiter)},
                          {"header", f.header},
                          {"names", f.names},
                          {"data_rows", f.data_rows},
                          {"blank_or_comment_lines", f.skipped_lines}});
  }
  for (const auto& [k, ref] : o.columns) j["columns"][k] = ref.text;
  j["units"] = {{"gyro", o.gyro_unit.text}, {"accel", o.accel_unit.text}};
  if (o.rate_hz)
    j["units"]["rate_hz"] = *o.rate_hz;
  else
    j["units"]["time"] = o.time_unit.text;
  j["samples"] = r.recording.imu.size();
  j["bad_rows"] = nlohmann::ordered_json::array();
  for (const BadRow& b : r.bad_rows)
    j["bad_rows"].push_back({{"where", b.where()}, {"why", b.why}});
  j["bad_rows_left_out"] = o.skip_bad_rows ? r.bad_rows.size() : 0;
  const TimingReport& t = r.timing;
  j["timing"] = {{"from_rate", t.from_rate},       {"median_dt_s", t.median_dt_s},
                 {"rate_hz", t.rate_hz},           {"jitter_rms_s", t.jitter_rms_s},
                 {"jitter_max_s", t.jitter_max_s}, {"min_dt_s", t.min_dt_s},
                 {"max_dt_s", t.max_dt_s},         {"gaps", nlohmann::ordered_json::array()}};
  for (const TimingGap& g : t.gaps)
    j["timing"]["gaps"].push_back({{"where", g.file + ":" + std::to_string(g.line)},
                                   {"t0", g.t0},
                                   {"t1", g.t1},
                                   {"dt_s", g.t1 - g.t0}});
  if (o.resample_hz) j["resampled_hz"] = *o.resample_hz;
  j["notes"] = r.notes;
  return j.dump(2) + "\n";
}

}  // namespace imubench::io
