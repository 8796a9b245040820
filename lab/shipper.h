// The lab mirror's shipper (issue 30): moves a bench's SQLite outbox (daemon/store.h OutboxItem)
// into the lab's PostgreSQL database.
//
// Delivery is at least once with an exactly-once effect: a batch is upserted in one PostgreSQL
// transaction keyed by (bench id, run id, item), and only after its COMMIT is it acknowledged
// (deleted) in SQLite. A crash between the two re-ships the batch, and the upserts make the second
// delivery change nothing. The bench id is the writing role (current_user), so a bench's writer
// writes only its own rows (the schema's row security).
//
// SQLite stays the source of truth: a fault (database down, partition, wrong password, missing
// rights, schema older or newer) leaves the outbox growing and is reported in MirrorStatus; once
// the fault ends the backlog drains. A bench never waits on the lab: LabMirror ships from its own
// thread over its own SQLite connection.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "daemon/store.h"
#include "lab/lab_connection.h"
#include "lab/sample_shipper.h"

namespace imubench::lab {

struct ShipperOptions {
  // Outbox entries per PostgreSQL transaction: large enough that a backlog of hours drains in
  // seconds, small enough that a batch re-shipped after a crash is cheap.
  std::size_t batch_items = 500;
  // How often an empty outbox is looked at again, s: results reach the lab within this.
  double idle_poll_s = 0.2;
  // Retry delay after a fault, s: doubles from min to max, so a down database is tried every
  // 10 s at most and a short outage recovers within a second.
  double retry_min_s = 0.5;
  double retry_max_s = 10.0;
  // [lab] mirror_samples: also copy the raw IMU, table and chamber rows (lab/sample_shipper.h).
  // Off by default: a 2 kHz IMU is ~7 million rows a hour, which a lab must plan for.
  bool mirror_samples = false;
  SampleShipOptions samples;

  bool IsValid(std::string* why) const;
};

// One step's outcome.
struct ShipStep {
  LabError error;                     // fault of this step (none: shipped or nothing to ship)
  int shipped = 0;                    // entries committed and acknowledged
  std::int64_t backlog = -1;          // entries still waiting (-1: unknown)
  std::int64_t samples_shipped = 0;   // raw sample rows committed (mirror_samples)
  std::int64_t samples_backlog = -1;  // raw sample rows still waiting (-1: unknown or off)
};

// Ships one batch per step() over one libpq connection (reconnecting after any fault). Not
// thread-safe; the store must outlive it.
class Shipper {
 public:
  Shipper(LabEndpoint endpoint, daemon::Store& store, ShipperOptions options = {});
  ShipStep step();

 private:
  LabError ensureConnected();
  LabError shipBatch(const std::vector<daemon::OutboxItem>& items);
  void disconnect();

  LabEndpoint endpoint_;
  daemon::Store* store_;
  ShipperOptions options_;
  PgConn conn_;
  SampleShipper samples_;
};

// What the daemon's `status` shows and its alarm says.
struct MirrorStatus {
  std::string state = "starting";  // starting, ok, fault
  LabFault fault = LabFault::kNone;
  std::string message;                // the fault, one line (no credentials)
  std::int64_t backlog = -1;          // outbox entries waiting (-1: not yet known)
  std::int64_t shipped = 0;           // entries shipped since start
  bool mirror_samples = false;        // raw samples are mirrored too (the two fields below)
  std::int64_t samples_backlog = -1;  // raw sample rows waiting (-1: not yet known)
  std::int64_t samples_shipped = 0;   // raw sample rows shipped since start
  double fault_since_unix_s = 0.0;    // when the current fault began (0: none)
};

// The shipper on its own thread, over its own connection to the bench's SQLite store.
class LabMirror {
 public:
  // Opens the store at store_path, enables its outbox (Store::enableOutbox) and starts shipping.
  static Result<std::unique_ptr<LabMirror>> start(const std::string& store_path,
                                                  const LabEndpoint& endpoint,
                                                  const ShipperOptions& options = {});
  ~LabMirror();  // stop()
  LabMirror(const LabMirror&) = delete;
  LabMirror& operator=(const LabMirror&) = delete;

  MirrorStatus status() const;
  // Ends the thread; waits for a step in progress (bounded by the connect and statement
  // timeouts).
  void stop();

 private:
  LabMirror(std::unique_ptr<daemon::Store> store, const LabEndpoint& endpoint,
            const ShipperOptions& options);
  void run();

  std::unique_ptr<daemon::Store> store_;
  Shipper shipper_;
  ShipperOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  MirrorStatus status_;
  std::thread thread_;
};

}  // namespace imubench::lab
