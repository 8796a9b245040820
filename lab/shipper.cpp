#include "lab/shipper.h"

#include <algorithm>
#include <chrono>
#include <utility>

namespace imubench::lab {
namespace {

// Idempotent: a re-shipped entry rewrites the same row with the same payload. The outbox_seq
// guard keeps an older entry from overwriting a newer one (shipping is in seq order anyway).
constexpr const char* kUpsertSql =
    "INSERT INTO lab.items(bench_id, run_id, item, kind, payload, outbox_seq) "
    "VALUES(current_user, $1::bigint, $2, $3, $4::jsonb, $5::bigint) "
    "ON CONFLICT (bench_id, run_id, item) DO UPDATE SET kind = EXCLUDED.kind, "
    "payload = EXCLUDED.payload, outbox_seq = EXCLUDED.outbox_seq, shipped_at = now() "
    "WHERE lab.items.outbox_seq <= EXCLUDED.outbox_seq";
constexpr const char* kDeleteSql =
    "DELETE FROM lab.items WHERE bench_id = current_user AND run_id = $1::bigint AND item = $2 "
    "AND outbox_seq <= $3::bigint";

double nowUnixS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

bool ShipperOptions::IsValid(std::string* why) const {
  if (batch_items < 1 || samples.batch_rows < 1 || !(idle_poll_s > 0.0) || !(retry_min_s > 0.0) ||
      !(retry_max_s >= retry_min_s)) {
    *why =
        "batch_items >= 1, samples.batch_rows >= 1, idle_poll_s > 0 and 0 < retry_min_s <= "
        "retry_max_s are required";
    return false;
  }
  return true;
}

Shipper::Shipper(LabEndpoint endpoint, daemon::Store& store, ShipperOptions options)
    : endpoint_(std::move(endpoint)),
      store_(&store),
      options_(options),
      samples_(store, options.samples) {}

void Shipper::disconnect() {
  conn_.reset();
  samples_.forget();
}

LabError Shipper::ensureConnected() {
  if (conn_ && PQstatus(conn_.get()) == CONNECTION_OK) return {};
  if (LabError e = connectLab(endpoint_, "imubenchd", &conn_); !e.ok()) return e;
  if (LabError e = checkLabSchema(conn_.get()); !e.ok()) {
    disconnect();
    return e;
  }
  return {};
}

LabError Shipper::shipBatch(const std::vector<daemon::OutboxItem>& items) {
  PGconn* c = conn_.get();
  auto exec = [c](const char* sql, const std::string& what) -> LabError {
    PgResult r(PQexec(c, sql));
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) return statementError(c, r.get(), what);
    return {};
  };
  if (LabError e = exec("BEGIN", "cannot begin a lab transaction"); !e.ok()) return e;
  for (const daemon::OutboxItem& it : items) {
    const std::string run = std::to_string(it.run_id);
    const std::string seq = std::to_string(it.seq);
    PgResult r;
    if (it.remove) {
      const char* values[] = {run.c_str(), it.item.c_str(), seq.c_str()};
      r.reset(PQexecParams(c, kDeleteSql, 3, nullptr, values, nullptr, nullptr, 0));
    } else {
      const char* values[] = {run.c_str(), it.item.c_str(), it.kind.c_str(), it.payload.c_str(),
                              seq.c_str()};
      r.reset(PQexecParams(c, kUpsertSql, 5, nullptr, values, nullptr, nullptr, 0));
    }
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) {
      LabError e = statementError(c, r.get(), "cannot ship run " + run + " " + it.item);
      PgResult(PQexec(c, "ROLLBACK"));
      return e;
    }
  }
  return exec("COMMIT", "cannot commit a lab transaction");
}

ShipStep Shipper::step() {
  ShipStep s;
  auto items = store_->outboxPeek(options_.batch_items);
  if (!items.ok()) {
    s.error = {LabFault::kOther, items.status.message};
    return s;
  }
  if (!items.value.empty()) {
    if (s.error = ensureConnected(); s.error.ok()) s.error = shipBatch(items.value);
    if (!s.error.ok()) {
      disconnect();  // a fixed password, role or server is picked up by the next connection
    } else if (Status st = store_->outboxAck(items.value.back().seq); !st.ok) {
      // Committed in the lab but not acknowledged: shipped again later, without effect.
      s.error = {LabFault::kOther, st.message};
    } else {
      s.shipped = static_cast<int>(items.value.size());
    }
  }
  // Then one batch of raw samples: results and events go first, samples fill the rest.
  if (options_.mirror_samples && s.error.ok()) {
    if (s.error = ensureConnected(); s.error.ok()) {
      const SampleStep ss = samples_.step(conn_.get());
      s.error = ss.error;
      s.samples_shipped = ss.shipped;
    }
    if (!s.error.ok()) disconnect();
  }
  if (auto b = store_->outboxBacklog(); b.ok()) s.backlog = b.value;
  if (options_.mirror_samples) {
    s.samples_backlog = samples_.backlog(
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count());
  }
  return s;
}

Result<std::unique_ptr<LabMirror>> LabMirror::start(const std::string& store_path,
                                                    const LabEndpoint& endpoint,
                                                    const ShipperOptions& options) {
  using R = Result<std::unique_ptr<LabMirror>>;
  std::string why;
  if (!endpoint.IsValid(&why)) return R::Error("[lab]: " + why);
  if (!options.IsValid(&why)) return R::Error("[lab]: " + why);
  if (Status st = checkConninfo(endpoint.conninfo); !st.ok) return R::Error("[lab]: " + st.message);
  auto store = daemon::Store::open(store_path);
  if (!store.ok()) return R::Error(store.status.message);
  if (Status st = store.value->enableOutbox(); !st.ok) return R::Error(st.message);
  std::unique_ptr<LabMirror> m(new LabMirror(std::move(store.value), endpoint, options));
  m->thread_ = std::thread([p = m.get()]() { p->run(); });
  return {Status::Ok(), std::move(m)};
}

LabMirror::LabMirror(std::unique_ptr<daemon::Store> store, const LabEndpoint& endpoint,
                     const ShipperOptions& options)
    : store_(std::move(store)), shipper_(endpoint, *store_, options), options_(options) {}

LabMirror::~LabMirror() {
  stop();
}

MirrorStatus LabMirror::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}

void LabMirror::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void LabMirror::run() {
  double retry_s = options_.retry_min_s;
  for (;;) {
    const ShipStep s = shipper_.step();
    double wait_s = 0.0;
    std::unique_lock<std::mutex> lock(mutex_);
    if (s.backlog >= 0) status_.backlog = s.backlog;
    status_.shipped += s.shipped;
    status_.mirror_samples = options_.mirror_samples;
    status_.samples_backlog = s.samples_backlog;
    status_.samples_shipped += s.samples_shipped;
    if (s.error.ok()) {
      status_.state = "ok";
      status_.fault = LabFault::kNone;
      status_.message.clear();
      status_.fault_since_unix_s = 0.0;
      retry_s = options_.retry_min_s;
      wait_s = s.shipped > 0 || s.samples_shipped > 0 ? 0.0 : options_.idle_poll_s;
    } else {
      if (status_.state != "fault") status_.fault_since_unix_s = nowUnixS();
      status_.state = "fault";
      status_.fault = s.error.fault;
      status_.message = s.error.message;
      wait_s = retry_s;
      retry_s = std::min(options_.retry_max_s, retry_s * 2.0);
    }
    if (stopping_) return;
    if (wait_s > 0.0) {
      wake_.wait_for(lock, std::chrono::duration<double>(wait_s), [this] { return stopping_; });
      if (stopping_) return;
    }
  }
}

}  // namespace imubench::lab
