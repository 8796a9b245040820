// The lab mirror's raw samples (issue 30, [lab] mirror_samples = true): copies a bench's IMU,
// table and chamber rows (daemon/store.h SampleStream) into the lab's PostgreSQL with COPY.
//
// Exactly once, by construction: a stream's rows of a run have strictly increasing times and
// are only ever appended after the newest stored one (Store::appendBatch), so "every row after
// time m" is all that is new. The lab keeps m per (bench, run, stream) in lab.sample_marks and
// updates it in the SAME PostgreSQL transaction as the rows it copies: rows and mark commit
// together or not at all, and the shipper reads the marks back from the lab after every
// (re)connection. A shipper killed at any point, or a COMMIT whose answer was lost, resumes
// after the committed mark; nothing in SQLite needs acknowledging. Rows go through COPY (binary,
// bit-exact doubles) into a temporary staging table and then INSERT ... SELECT ... ON CONFLICT
// DO NOTHING into the lab table (COPY cannot write a table with row security): a mark lost or
// reset by hand re-ships rows without duplicating them.
//
// The SQLite store is only read (its own connection on the shipper's thread): the bench's writer
// never waits for the lab.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <utility>

#include "daemon/store.h"
#include "lab/lab_connection.h"

namespace imubench::lab {

struct SampleShipOptions {
  // Rows per PostgreSQL transaction (one stream of one run): 5 s of a 2 kHz IMU; large enough
  // that COPY's per-transaction costs vanish, small enough for a quick retry after a fault.
  std::size_t batch_rows = 10000;
  // The backlog (rows not yet in the lab) is counted at most this often, s: counting walks the
  // waiting rows, which after a long outage are millions.
  double backlog_every_s = 1.0;
};

struct SampleStep {
  LabError error;
  std::int64_t shipped = 0;  // rows committed in the lab by this step
};

// Not thread-safe; one per Shipper. The store must outlive it.
class SampleShipper {
 public:
  SampleShipper(daemon::Store& store, SampleShipOptions options);
  // Ships the oldest waiting batch over `conn` (connected, schema checked). Reads the lab's
  // marks first when they are not known (forget()).
  SampleStep step(PGconn* conn);
  // The connection was lost or reset: the marks are read again from the lab before shipping.
  void forget() { marks_known_ = false; }
  // Rows waiting (-1: unknown, the lab was never reached); recounted every backlog_every_s.
  std::int64_t backlog(double now_s);

 private:
  using Key = std::pair<std::int64_t, daemon::SampleStream>;
  LabError readMarks(PGconn* conn);
  LabError shipRows(PGconn* conn, const daemon::SampleRows& rows, std::int64_t run_id);

  daemon::Store* store_;
  SampleShipOptions options_;
  bool marks_known_ = false;
  bool ever_known_ = false;      // the last marks read (or shipped) stand for the backlog
  std::map<Key, double> marks_;  // shipped_t per run and stream
  std::int64_t backlog_ = -1;
  double backlog_at_s_ = -1e300;
};

}  // namespace imubench::lab
