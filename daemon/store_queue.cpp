// The run store's plan queue (daemon/store.h): the plans waiting to start, in order.
#include <sqlite3.h>

#include <algorithm>
#include <string>
#include <vector>

#include "daemon/store.h"
#include "daemon/store_internal.h"

namespace imubench::daemon {

using store_internal::Bound;
using store_internal::nowUnixS;

// The queue's entry ids in order.
Status Store::Impl::queueIds(std::vector<std::int64_t>* ids) {
  Status st;
  Bound q = use("SELECT id FROM queue ORDER BY pos, id", &st);
  if (!q) return st;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) ids->push_back(q.integer(0));
  if (rc != SQLITE_DONE) return sqlError("cannot read the queue");
  return Status::Ok();
}

QueueAddResult Store::queueAdd(const QueueEntry& entry) {
  QueueAddResult r;
  r.status = impl_->transaction("cannot queue plan '" + entry.plan_name + "'", [&]() {
    Status st;
    Bound q = impl_->use(
        "INSERT INTO queue(pos, plan_name, source, plan_toml, label, added_unix_s) "
        "VALUES((SELECT coalesce(max(pos), 0) + 1 FROM queue), ?1, ?2, ?3, ?4, ?5)",
        &st);
    if (!q) return st;
    q.bindAll(entry.plan_name, entry.source, entry.plan_toml, entry.label, nowUnixS());
    if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot queue the plan");
    r.value.entry_id = sqlite3_last_insert_rowid(impl_->db.get());
    std::int64_t count = 0;
    st = impl_->queryInt("SELECT count(*) FROM queue", "cannot count the queue", &count);
    r.value.position = static_cast<int>(count);
    return st;
  });
  if (!r.status.ok) r.value.entry_id = 0;
  return r;
}

QueueListResult Store::queueList() {
  QueueListResult r;
  Bound q = impl_->use(
      "SELECT id, plan_name, source, plan_toml, label, added_unix_s FROM queue ORDER BY pos, id",
      &r.status);
  if (!q) return r;
  int rc;
  while ((rc = q.step()) == SQLITE_ROW) {
    r.value.push_back({q.integer(0), q.text(1), q.text(2), q.text(3), q.text(4), q.real(5)});
  }
  if (rc != SQLITE_DONE) r.status = impl_->sqlError("cannot read the queue");
  return r;
}

Status Store::queueMove(std::int64_t entry_id, int position) {
  const std::string what = "queue entry " + std::to_string(entry_id);
  return impl_->transaction("cannot move " + what, [&]() {
    std::vector<std::int64_t> ids;
    if (auto st = impl_->queueIds(&ids); !st.ok) return st;
    const auto it = std::find(ids.begin(), ids.end(), entry_id);
    if (it == ids.end()) return impl_->error(what + " not found");
    if (position < 1 || static_cast<std::size_t>(position) > ids.size()) {
      return impl_->error("position " + std::to_string(position) + " is outside 1.." +
                          std::to_string(ids.size()));
    }
    ids.erase(it);
    ids.insert(ids.begin() + (position - 1), entry_id);
    Status st;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      Bound q = impl_->use("UPDATE queue SET pos = ?2 WHERE id = ?1", &st);
      if (!q) return st;
      q.bind(1, ids[i]);
      q.bind(2, static_cast<std::int64_t>(i + 1));
      if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot move " + what);
    }
    return Status::Ok();
  });
}

Status Store::queueRemove(std::int64_t entry_id) {
  const std::string what = "queue entry " + std::to_string(entry_id);
  Status st;
  Bound q = impl_->use("DELETE FROM queue WHERE id = ?1", &st);
  if (!q) return st;
  q.bind(1, entry_id);
  if (q.step() != SQLITE_DONE) return impl_->sqlError("cannot remove " + what);
  if (sqlite3_changes(impl_->db.get()) == 0) return impl_->error(what + " not found");
  return Status::Ok();
}

}  // namespace imubench::daemon
