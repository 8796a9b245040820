// The run store's lab outbox (daemon/store.h, OutboxItem): enabling it, and what the lab
// mirror's shipper peeks and acknowledges. Its table, views and triggers are part of the schema
// (daemon/store.cpp, kOutboxSchemaSql).
#include <sqlite3.h>

#include <string>

#include "daemon/store.h"
#include "daemon/store_internal.h"

namespace imubench::daemon {
namespace {

// enableOutbox's backfill: everything stored before the outbox was enabled, in a stable order.
constexpr const char* kOutboxBackfillSql = R"sql(
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_runs ORDER BY run_id;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_segments;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_events;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_results;
INSERT INTO lab_outbox(run_id, item, kind, op, payload)
  SELECT run_id, item, kind, 'upsert', payload FROM lab_item_queue;
INSERT INTO lab_outbox_enabled VALUES(1);
)sql";

}  // namespace

using store_internal::Bound;

Status Store::enableOutbox() {
  return impl_->transaction("cannot enable the lab outbox", [&]() {
    std::int64_t enabled = 0;
    if (auto st = impl_->queryInt("SELECT count(*) FROM lab_outbox_enabled",
                                  "cannot read the lab outbox", &enabled);
        !st.ok || enabled != 0) {
      return st;
    }
    return impl_->execSql(kOutboxBackfillSql, "cannot fill the lab outbox");
  });
}

OutboxListResult Store::outboxPeek(std::size_t limit) {
  OutboxListResult r;
  Bound q = impl_->use(
      "SELECT seq, run_id, item, kind, op, payload FROM lab_outbox ORDER BY seq LIMIT ?1",
      &r.status);
  if (!q) return r;
  q.bind(1, static_cast<std::int64_t>(limit));
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.push_back(
        {q.integer(0), q.integer(1), q.text(2), q.text(3), q.text(4) == "delete", q.text(5)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read the lab outbox");
  return r;
}

Status Store::outboxAck(std::int64_t up_to_seq) {
  Status st;
  Bound q = impl_->use("DELETE FROM lab_outbox WHERE seq <= ?1", &st);
  if (!q) return st;
  q.bind(1, up_to_seq);
  if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot acknowledge the lab outbox");
  return Status::Ok();
}

CountResult Store::outboxBacklog() {
  CountResult r;
  std::int64_t n = 0;
  r.status = impl_->queryInt("SELECT count(*) FROM lab_outbox", "cannot count the lab outbox", &n);
  r.value = static_cast<int>(n);
  return r;
}

}  // namespace imubench::daemon
