#include "lab/sample_shipper.h"

#include <endian.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace imubench::lab {
namespace {

using daemon::SampleStream;

// The stream's SQL: staging table, copy into it, move into the lab table.
struct StreamStatements {
  std::string create_stage;
  std::string copy;
  std::string insert;
};

StreamStatements statementsFor(SampleStream stream) {
  const std::string name = daemon::sampleStreamName(stream);
  const std::string stage = "lab_stage_" + name;
  std::string cols = "t";
  std::string typed = "t float8";
  for (const char* c : daemon::sampleColumns(stream)) {
    cols += std::string(", ") + c;
    typed += std::string(", ") + c + " float8";
  }
  StreamStatements s;
  // Temporary: not WAL-logged, private to the connection, emptied at every commit.
  s.create_stage =
      "CREATE TEMP TABLE IF NOT EXISTS " + stage + "(" + typed + ") ON COMMIT DELETE ROWS";
  s.copy = "COPY " + stage + "(" + cols + ") FROM STDIN (FORMAT binary)";
  s.insert = "INSERT INTO lab." + name + "_samples(bench_id, run_id, " + cols +
             ") SELECT current_user, $1::bigint, " + cols + " FROM " + stage +
             " ON CONFLICT DO NOTHING";
  return s;
}

const StreamStatements& statements(SampleStream stream) {
  static const StreamStatements kImu = statementsFor(SampleStream::kImu);
  static const StreamStatements kTable = statementsFor(SampleStream::kTable);
  static const StreamStatements kChamber = statementsFor(SampleStream::kChamber);
  if (stream == SampleStream::kTable) return kTable;
  if (stream == SampleStream::kChamber) return kChamber;
  return kImu;
}

// The mark moves forward only (a re-shipped older batch cannot pull it back).
constexpr const char* kMarkSql =
    "INSERT INTO lab.sample_marks(bench_id, run_id, stream, shipped_t, shipped_rows) "
    "VALUES(current_user, $1::bigint, $2, $3::float8, $4::bigint) "
    "ON CONFLICT (bench_id, run_id, stream) DO UPDATE SET "
    "shipped_t = greatest(lab.sample_marks.shipped_t, EXCLUDED.shipped_t), "
    "shipped_rows = lab.sample_marks.shipped_rows + EXCLUDED.shipped_rows, updated_at = now()";
// Binary results: shipped_t exactly as stored.
constexpr const char* kReadMarksSql =
    "SELECT run_id, stream, shipped_t FROM lab.sample_marks WHERE bench_id = current_user";

void putInt16(std::vector<char>& out, std::int16_t v) {
  const std::uint16_t be = htobe16(static_cast<std::uint16_t>(v));
  out.insert(out.end(), reinterpret_cast<const char*>(&be), reinterpret_cast<const char*>(&be) + 2);
}
void putInt32(std::vector<char>& out, std::int32_t v) {
  const std::uint32_t be = htobe32(static_cast<std::uint32_t>(v));
  out.insert(out.end(), reinterpret_cast<const char*>(&be), reinterpret_cast<const char*>(&be) + 4);
}
// A float8 field; NaN is the store's NULL (never a value: the store refuses NaN elsewhere).
void putDouble(std::vector<char>& out, double v) {
  if (std::isnan(v)) {
    putInt32(out, -1);
    return;
  }
  putInt32(out, 8);
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, 8);
  bits = htobe64(bits);
  out.insert(out.end(), reinterpret_cast<const char*>(&bits),
             reinterpret_cast<const char*>(&bits) + 8);
}

// PostgreSQL's binary COPY format: signature, flags, header extension, tuples, trailer.
std::vector<char> binaryCopy(const daemon::SampleRows& rows) {
  static constexpr char kSignature[] = "PGCOPY\n\377\r\n";  // + its terminating NUL: 11 bytes
  std::vector<char> out(kSignature, kSignature + 11);
  out.reserve(19 + rows.size() * (2 + 12 * (rows.columns + 1)) + 2);
  putInt32(out, 0);
  putInt32(out, 0);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    putInt16(out, static_cast<std::int16_t>(rows.columns + 1));
    putDouble(out, rows.t[i]);
    for (std::size_t c = 0; c < rows.columns; ++c)
      putDouble(out, rows.values[i * rows.columns + c]);
  }
  putInt16(out, -1);
  return out;
}

double beDouble(const char* p) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, p, 8);
  bits = be64toh(bits);
  double v = 0.0;
  std::memcpy(&v, &bits, 8);
  return v;
}

std::int64_t beInt64(const char* p) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, p, 8);
  return static_cast<std::int64_t>(be64toh(bits));
}

LabError command(PGconn* c, const char* sql, const std::string& what) {
  PgResult r(PQexec(c, sql));
  if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) return statementError(c, r.get(), what);
  return {};
}

// COPY the rows into the staging table (inside the caller's transaction).
LabError copyRows(PGconn* c, const daemon::SampleRows& rows, const std::string& what) {
  PgResult start(PQexec(c, statements(rows.stream).copy.c_str()));
  if (PQresultStatus(start.get()) != PGRES_COPY_IN) return statementError(c, start.get(), what);
  const std::vector<char> data = binaryCopy(rows);
  const bool sent = PQputCopyData(c, data.data(), static_cast<int>(data.size())) == 1;
  if (PQputCopyEnd(c, sent ? nullptr : "imubench: cannot send the rows") != 1) {
    return statementError(c, nullptr, what);
  }
  LabError e;
  for (PGresult* raw; (raw = PQgetResult(c)) != nullptr;) {
    PgResult r(raw);
    if (e.ok() && PQresultStatus(r.get()) != PGRES_COMMAND_OK) e = statementError(c, r.get(), what);
  }
  return e;
}

}  // namespace

SampleShipper::SampleShipper(daemon::Store& store, SampleShipOptions options)
    : store_(&store), options_(options) {}

LabError SampleShipper::readMarks(PGconn* c) {
  PgResult r(PQexecParams(c, kReadMarksSql, 0, nullptr, nullptr, nullptr, nullptr, 1));
  if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) {
    return statementError(c, r.get(), "cannot read the lab's sample marks");
  }
  marks_.clear();
  for (int i = 0; i < PQntuples(r.get()); ++i) {
    const std::string stream(PQgetvalue(r.get(), i, 1), PQgetlength(r.get(), i, 1));
    for (const SampleStream s : daemon::kSampleStreams) {
      if (stream == daemon::sampleStreamName(s)) {
        marks_[{beInt64(PQgetvalue(r.get(), i, 0)), s}] = beDouble(PQgetvalue(r.get(), i, 2));
      }
    }
  }
  marks_known_ = ever_known_ = true;
  backlog_at_s_ = -1e300;  // recount against the lab's marks
  return {};
}

LabError SampleShipper::shipRows(PGconn* c, const daemon::SampleRows& rows, std::int64_t run_id) {
  const std::string stream = daemon::sampleStreamName(rows.stream);
  const std::string what = "cannot ship " + stream + " samples of run " + std::to_string(run_id);
  const StreamStatements& sql = statements(rows.stream);
  if (LabError e = command(c, "BEGIN", what); !e.ok()) return e;
  LabError e = command(c, sql.create_stage.c_str(), what);
  if (e.ok()) e = copyRows(c, rows, what);
  std::string inserted = "0";
  const std::string run = std::to_string(run_id);
  if (e.ok()) {
    const char* values[] = {run.c_str()};
    PgResult r(PQexecParams(c, sql.insert.c_str(), 1, nullptr, values, nullptr, nullptr, 0));
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) {
      e = statementError(c, r.get(), what);
    } else {
      inserted = PQcmdTuples(r.get());
    }
  }
  if (e.ok()) {
    char last[40];
    std::snprintf(last, sizeof last, "%.17g", rows.t.back());
    const char* values[] = {run.c_str(), stream.c_str(), last, inserted.c_str()};
    PgResult r(PQexecParams(c, kMarkSql, 4, nullptr, values, nullptr, nullptr, 0));
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) e = statementError(c, r.get(), what);
  }
  if (!e.ok()) {
    PgResult(PQexec(c, "ROLLBACK"));
    return e;
  }
  return command(c, "COMMIT", what);
}

SampleStep SampleShipper::step(PGconn* c) {
  SampleStep s;
  if (!marks_known_) {
    if (s.error = readMarks(c); !s.error.ok()) return s;
  }
  const auto tails = store_->sampleTails();
  if (!tails.ok()) {
    s.error = {LabFault::kOther, tails.status.message};
    return s;
  }
  for (const daemon::SampleTail& tail : tails.value) {
    const Key key{tail.run_id, tail.stream};
    const auto mark = marks_.find(key);
    const std::optional<double> after =
        mark == marks_.end() ? std::nullopt : std::optional<double>(mark->second);
    if (after && !(tail.newest_t > *after)) continue;
    const auto rows = store_->readSamples(tail.run_id, tail.stream, after, options_.batch_rows);
    if (!rows.ok()) {
      s.error = {LabFault::kOther, rows.status.message};
      return s;
    }
    if (rows.value.size() == 0) continue;
    if (s.error = shipRows(c, rows.value, tail.run_id); !s.error.ok()) {
      marks_known_ = false;  // the COMMIT's outcome may be unknown: ask the lab
      return s;
    }
    marks_[key] = rows.value.t.back();
    s.shipped = static_cast<std::int64_t>(rows.value.size());
    if (backlog_ >= 0) backlog_ = std::max<std::int64_t>(0, backlog_ - s.shipped);
    return s;
  }
  return s;
}

std::int64_t SampleShipper::backlog(double now_s) {
  if (!ever_known_) return -1;
  if (now_s - backlog_at_s_ < options_.backlog_every_s) return backlog_;
  const auto tails = store_->sampleTails();
  if (!tails.ok()) return backlog_;
  std::int64_t n = 0;
  for (const daemon::SampleTail& tail : tails.value) {
    const auto mark = marks_.find({tail.run_id, tail.stream});
    const std::optional<double> after =
        mark == marks_.end() ? std::nullopt : std::optional<double>(mark->second);
    if (after && !(tail.newest_t > *after)) continue;
    const auto count = store_->countSamples(tail.run_id, tail.stream, after);
    if (!count.ok()) return backlog_;
    n += count.value;
  }
  backlog_ = n;
  backlog_at_s_ = now_s;
  return backlog_;
}

}  // namespace imubench::lab
