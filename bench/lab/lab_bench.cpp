// The lab mirror's throughput into a local throwaway PostgreSQL (issue 30), end to end: a
// cluster started with tools/lab-db.sh in a temporary directory (stopped and removed at the
// end), the benches' SQLite stores beside it. Wall-clock phases, not a Google Benchmark loop:
//
//   items     one bench's backlog of outbox items (runs, events, results, segments) -> items/s
//   samples   one bench's backlog of raw samples (mirror_samples; 2 kHz IMU, 100 Hz table,
//             1 Hz chamber) -> samples/s
//   backlog   B benches (default 20) draining their sample backlogs at once into the one
//             database -> aggregate samples/s
//   loop      one bench writing at 2 kHz through RunWriter for 20 s, first without a mirror,
//             then while its LabMirror drains a 600 s backlog flat out: the append latency
//             percentiles (what the daemon's loop waits for its store)
//   baseline, realtime
//             B benches writing 2 kHz IMU + 100 Hz table (+ 1 Hz chamber) through RunWriter
//             for D s (default 30), without and then with their LabMirrors shipping: the
//             writers' append latency, how far the lab was behind when the writers stopped and
//             when it had everything, and then: no sample lost or doubled (lab rows == SQLite
//             rows, per bench)
//
// Target (issue 30): 20 benches' 2 kHz samples in real time into one local PostgreSQL on this
// machine: 20 x (2000 IMU + 100 table + 1 chamber) = 42,020 rows/s. Printed as ratios (> 1:
// the target is met). The benches' writers and shippers run on this machine too (in reality
// they run on the bench computers): a conservative setting.
//
// Usage: imubench_lab_bench [--benches B] [--seconds D] [--backlog-s S]
// Exit 0 when the run completed (whatever the ratios), 1 when a phase failed.
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "daemon/store.h"
#include "lab/shipper.h"

namespace {

namespace daemon = imubench::daemon;
namespace lab = imubench::lab;
namespace nav = imubench::nav;
using imubench::Status;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kImuHz = 2000.0;
constexpr int kImuBatch = 20;    // 10 ms of IMU per append, as the IMU reader hands them over
constexpr int kTableEvery = 20;  // one table reading per 20 IMU samples: 100 Hz
constexpr int kChamberEvery = 2000;
constexpr double kTargetBenches = 20.0;
constexpr double kTargetRowsPerS = kTargetBenches * (2000.0 + 100.0 + 1.0);

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

int shell(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// The throwaway cluster and the benches' writer roles.
class Cluster {
 public:
  explicit Cluster(const std::string& root) : dir_(root + "/cluster") {
    port_ = 20000 + static_cast<int>(::getpid() % 20000);
    ok_ = shell(script() + " init " + dir_ + " " + std::to_string(port_) + " > " + root +
                "/init.log 2>&1") == 0;
  }
  ~Cluster() {
    if (ok_) shell(script() + " stop " + dir_ + " > /dev/null 2>&1");
  }
  bool ok() const { return ok_; }
  lab::LabEndpoint addBench(const std::string& name) const {
    lab::LabEndpoint e;
    if (shell(script() + " add-bench " + dir_ + " " + name) != 0) return e;
    e.conninfo = "postgresql://" + name + "@127.0.0.1:" + std::to_string(port_) + "/lab";
    e.password_file = dir_ + "/secrets/" + name + ".pass";
    return e;
  }
  std::string psql(const std::string& sql) const {
    const std::string cmd = script() + " psql " + dir_ + " -At -c \"" + sql + "\"";
    std::string out;
    if (FILE* p = ::popen(cmd.c_str(), "r")) {
      char buf[256];
      while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
      ::pclose(p);
    }
    while (!out.empty() && out.back() == '\n') out.pop_back();
    return out;
  }

 private:
  static std::string script() { return std::string(IMUBENCH_SOURCE_DIR) + "/tools/lab-db.sh"; }
  std::string dir_;
  int port_ = 0;
  bool ok_ = false;
};

// n IMU samples from index first (2 kHz), with the table and chamber rows in between.
daemon::RunBatch samples(std::mt19937_64& rng, long first, long n) {
  std::normal_distribution<double> noise(0.0, 1.0);
  daemon::RunBatch b;
  for (long i = first; i < first + n; ++i) {
    nav::ImuSample s;
    s.t = static_cast<double>(i + 1) / kImuHz;
    s.dtheta = imubench::Vec3(noise(rng), noise(rng), noise(rng)) * 1e-7;
    s.dvel = imubench::Vec3(noise(rng) * 5e-6, noise(rng) * 5e-6, 9.8155 / kImuHz);
    s.temp_c = 25.0 + 0.01 * noise(rng);
    b.imu.push_back(s);
    if (i % kTableEvery == 0) b.table.push_back({s.t, {10.0 * s.t, 90.0, 0.0}});
    if (i % kChamberEvery == 0) b.chamber.push_back({s.t, 25.0, 25.0 + 0.1 * noise(rng)});
  }
  return b;
}

std::int64_t beginRun(daemon::Store& store) {
  daemon::RunStart start;
  start.plan_name = "lab bench";
  start.plan_toml = "[plan]";
  start.bench_name = "bench";
  start.imu_serial = "SN-BENCH";
  start.imu_rate_hz = kImuHz;
  const auto id = store.beginRun(start);
  return id.ok() ? id.value : -1;
}

std::unique_ptr<daemon::Store> openStore(const std::string& path) {
  auto s = daemon::Store::open(path);
  if (!s.ok()) std::cerr << s.status.message << "\n";
  return s.ok() ? std::move(s.value) : nullptr;
}

long rowsOf(long imu) {
  return imu + (imu + kTableEvery - 1) / kTableEvery + (imu + kChamberEvery - 1) / kChamberEvery;
}

// Items: runs with events, segments and results, shipped from the outbox.
bool itemsPhase(const Cluster& cluster, const std::string& root) {
  auto store = openStore(root + "/items.db");
  const lab::LabEndpoint ep = cluster.addBench("items_bench");
  if (!store || !store->enableOutbox().ok) return false;
  // 20 runs of 1000 segments (one outbox item each, one transaction per run), an event and a
  // result each: 20,080 items.
  for (int r = 0; r < 20; ++r) {
    const std::int64_t run = beginRun(*store);
    daemon::RunBatch batch;
    for (int k = 0; k < 1000; ++k) {
      imubench::calib::Segment seg;
      seg.t0 = 10.0 * k;
      seg.t1 = seg.t0 + 5.0;
      seg.label = "step " + std::to_string(k);
      batch.segments.push_back(seg);
    }
    if (!store->appendBatch(run, batch).ok) return false;
    if (!store->addEvent({run, 0.0, daemon::EventSeverity::kInfo, "step_finished", "{}"}).ok ||
        !store->storeResult(run, "SN-BENCH", 25.0, "coefficients", "{\"bias\":[1,2,3]}").ok() ||
        !store->finishRun(run, daemon::RunState::kFinished, "").ok) {
      return false;
    }
  }
  const auto items = store->outboxBacklog();
  lab::Shipper shipper(ep, *store);
  const auto t0 = Clock::now();
  for (;;) {
    const lab::ShipStep s = shipper.step();
    if (!s.error.ok()) {
      std::cerr << "items: " << s.error.message << "\n";
      return false;
    }
    if (s.backlog == 0) break;
  }
  const double dt = secondsSince(t0);
  std::printf("items:    %d outbox items shipped in %.2f s: %.0f items/s (batches of 500)\n",
              items.value, dt, items.value / dt);
  return true;
}

lab::ShipperOptions sampleOptions() {
  lab::ShipperOptions o;
  o.mirror_samples = true;
  o.idle_poll_s = 0.05;
  o.retry_min_s = 0.1;
  o.retry_max_s = 1.0;
  return o;
}

// A bench's store holding `seconds` of samples in one running run.
std::unique_ptr<daemon::Store> filledStore(const std::string& path, double seconds, int seed) {
  auto store = openStore(path);
  if (!store) return nullptr;
  const std::int64_t run = beginRun(*store);
  std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
  const long n = static_cast<long>(seconds * kImuHz);
  for (long i = 0; i < n; i += 10000) {
    if (!store->appendBatch(run, samples(rng, i, std::min(10000L, n - i))).ok) return nullptr;
  }
  return store;
}

// B benches' sample backlogs drained at once (B = 1: one bench), each shipper on its thread.
bool backlogPhase(const Cluster& cluster, const std::string& root, int benches, double backlog_s,
                  const char* name) {
  std::vector<std::unique_ptr<daemon::Store>> stores;
  std::vector<lab::LabEndpoint> eps;
  for (int b = 0; b < benches; ++b) {
    const std::string bench = std::string(name) + std::to_string(b);
    stores.push_back(filledStore(root + "/" + bench + ".db", backlog_s, b));
    eps.push_back(cluster.addBench(bench));
    if (!stores.back() || !stores.back()->enableOutbox().ok) return false;
  }
  std::atomic<bool> failed{false};
  std::vector<std::thread> threads;
  const auto t0 = Clock::now();
  for (int b = 0; b < benches; ++b) {
    threads.emplace_back([&, b] {
      lab::Shipper shipper(eps[static_cast<std::size_t>(b)], *stores[static_cast<std::size_t>(b)],
                           sampleOptions());
      for (;;) {
        const lab::ShipStep s = shipper.step();
        if (!s.error.ok()) {
          std::cerr << name << b << ": " << s.error.message << "\n";
          failed = true;
          return;
        }
        if (s.samples_backlog == 0 && s.backlog == 0) return;
      }
    });
  }
  for (auto& t : threads) t.join();
  const double dt = secondsSince(t0);
  const double rows = static_cast<double>(benches) * rowsOf(static_cast<long>(backlog_s * kImuHz));
  std::printf(
      "%-9s %d bench(es) x %.0f s of samples (%.0f rows) shipped in %.2f s: %.0f samples/s"
      " (%.2f x the 20-bench target of %.0f rows/s)\n",
      (std::string(name) + ":").c_str(), benches, backlog_s, rows, dt, rows / dt,
      rows / dt / kTargetRowsPerS, kTargetRowsPerS);
  return !failed;
}

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

// One bench's writer: 2 kHz in 10 ms appends through RunWriter for `seconds`; each append's
// wall time goes to *latency_s. Returns the IMU samples written (-1: a write failed).
long writeRealTime(daemon::Store& store, double seconds, int seed, std::vector<double>* latency_s) {
  const std::int64_t run = beginRun(store);
  daemon::RunWriter writer(store, run);
  std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
  const auto t0 = Clock::now();
  long i = 0;
  for (auto next = t0; secondsSince(t0) < seconds; i += kImuBatch) {
    next += std::chrono::milliseconds(10);
    std::this_thread::sleep_until(next);
    const daemon::RunBatch b = samples(rng, i, kImuBatch);
    const auto a0 = Clock::now();
    Status st = writer.appendImu(b.imu);
    if (st.ok && !b.table.empty()) st = writer.appendTable(b.table);
    if (st.ok && !b.chamber.empty()) st = writer.appendChamber(b.chamber);
    latency_s->push_back(secondsSince(a0));
    if (!st.ok) {
      std::cerr << st.message << "\n";
      return -1;
    }
  }
  return writer.flush().ok ? i : -1;
}

struct RealTimeBench {
  std::unique_ptr<daemon::Store> store;
  std::unique_ptr<lab::LabMirror> mirror;
  std::vector<double> latency_s;
  long imu = 0;
};

// Rows of the benches named PREFIX<n> in the lab (all three streams).
long labRows(const Cluster& cluster, const std::string& bench_like) {
  std::string sql = "SELECT 0";
  for (const char* t : {"lab.imu_samples", "lab.table_samples", "lab.chamber_samples"}) {
    sql +=
        std::string(" + (SELECT count(*) FROM ") + t + " WHERE bench_id LIKE '" + bench_like + "')";
  }
  return std::atol(cluster.psql(sql).c_str());
}

// Every bench's lab rows equal its SQLite rows (the PK forbids doubles; counts find losses).
bool compareCounts(const Cluster& cluster, const std::vector<RealTimeBench>& benches) {
  bool same = true;
  for (std::size_t b = 0; b < benches.size(); ++b) {
    const std::string name = "rt" + std::to_string(b);
    const long want = rowsOf(benches[b].imu);
    const long got = labRows(cluster, name);
    if (got != want) {
      std::printf("realtime: %s: %ld rows in the lab, %ld in SQLite\n", name.c_str(), got, want);
      same = false;
    }
  }
  return same;
}

void printLatency(const char* what, std::vector<double>& all) {
  std::printf(
      "%-9s writer append latency (RunWriter, 10 ms of samples, SQLite commit every 0.5 s)"
      " over %zu appends: p50 %.3f ms, p99 %.3f ms, p99.9 %.3f ms, max %.3f ms\n",
      what, all.size(), 1e3 * percentile(all, 0.5), 1e3 * percentile(all, 0.99),
      1e3 * percentile(all, 0.999), 1e3 * percentile(all, 1.0));
}

// The daemon's loop while its mirror ships flat out: one bench writes at 2 kHz for `seconds`
// while its LabMirror drains a 600 s backlog (mirror) or without a mirror (baseline).
bool loopPhase(const Cluster& cluster, const std::string& root, double seconds, bool mirror) {
  const std::string name = mirror ? "loop_mirror" : "loop_base";
  auto store = filledStore(root + "/" + name + ".db", 600.0, 7);
  if (!store) return false;
  std::unique_ptr<lab::LabMirror> m;
  if (mirror) {
    auto started = lab::LabMirror::start(store->path(), cluster.addBench(name), sampleOptions());
    if (!started.ok()) return false;
    m = std::move(started.value);
    while (m->status().samples_shipped == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::vector<double> latency;
  const std::int64_t before = m ? m->status().samples_shipped : 0;
  const long imu = writeRealTime(*store, seconds, 8, &latency);
  if (m) {
    const lab::MirrorStatus st = m->status();
    std::printf(
        "loop:     one bench at 2 kHz for %.0f s while its mirror shipped %lld rows "
        "(%.0f rows/s; %lld still waiting: %s)\n",
        seconds, static_cast<long long>(st.samples_shipped - before),
        static_cast<double>(st.samples_shipped - before) / seconds,
        static_cast<long long>(st.samples_backlog),
        st.samples_backlog > 0 ? "shipping throughout" : "the backlog ran out before the end");
  } else {
    std::printf("loop:     one bench at 2 kHz for %.0f s, no mirror\n", seconds);
  }
  printLatency(mirror ? "loop:" : "loop base:", latency);
  return imu > 0;
}

// The benches' writers alone, without a mirror: the latency the loop has without shipping.
bool baselinePhase(const std::string& root, int benches, double seconds) {
  std::vector<RealTimeBench> rt(static_cast<std::size_t>(benches));
  std::vector<std::thread> writers;
  for (int b = 0; b < benches; ++b) {
    auto& r = rt[static_cast<std::size_t>(b)];
    r.store = openStore(root + "/base" + std::to_string(b) + ".db");
    if (!r.store) return false;
    writers.emplace_back(
        [&r, seconds, b] { r.imu = writeRealTime(*r.store, seconds, b, &r.latency_s); });
  }
  for (auto& t : writers) t.join();
  std::vector<double> all;
  for (auto& r : rt) all.insert(all.end(), r.latency_s.begin(), r.latency_s.end());
  std::printf("baseline: %d benches x %.0f s at 2 kHz, no lab mirror\n", benches, seconds);
  printLatency("baseline:", all);
  return std::all_of(rt.begin(), rt.end(), [](const RealTimeBench& r) { return r.imu > 0; });
}

bool realTimePhase(const Cluster& cluster, const std::string& root, int benches, double seconds) {
  std::vector<RealTimeBench> rt(static_cast<std::size_t>(benches));
  for (int b = 0; b < benches; ++b) {
    auto& r = rt[static_cast<std::size_t>(b)];
    const std::string name = "rt" + std::to_string(b);
    r.store = openStore(root + "/" + name + ".db");
    const lab::LabEndpoint ep = cluster.addBench(name);
    if (!r.store) return false;
    auto m = lab::LabMirror::start(r.store->path(), ep, sampleOptions());
    if (!m.ok()) return false;
    r.mirror = std::move(m.value);
  }
  std::vector<std::thread> writers;
  for (int b = 0; b < benches; ++b) {
    writers.emplace_back([&, b] {
      auto& r = rt[static_cast<std::size_t>(b)];
      r.imu = writeRealTime(*r.store, seconds, b, &r.latency_s);
    });
  }
  for (auto& t : writers) t.join();
  const auto stopped = Clock::now();
  long produced = 0;
  std::vector<double> all;
  for (auto& r : rt) {
    produced += rowsOf(std::max(0L, r.imu));
    all.insert(all.end(), r.latency_s.begin(), r.latency_s.end());
  }
  // How far the lab was behind when the writers stopped, and when it had everything (each
  // count is a psql run of ~0.3 s on this machine: the times include it).
  const long lag = produced - labRows(cluster, "rt%");
  const double lag_at_s = secondsSince(stopped);
  while (labRows(cluster, "rt%") < produced && secondsSince(stopped) < 600) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const double complete_at_s = secondsSince(stopped);
  for (auto& r : rt) r.mirror->stop();
  const double input = static_cast<double>(produced) / seconds;
  std::printf(
      "realtime: %d benches x %.0f s at 2 kHz (%ld rows, %.0f rows/s = %.2f x the target's "
      "input) with mirror_samples: %ld rows (%.2f s of input) not yet in the lab %.2f s "
      "after the writers stopped, every row there %.2f s after: %s\n",
      benches, seconds, produced, input, input / kTargetRowsPerS, lag,
      static_cast<double>(lag) / input, lag_at_s, complete_at_s,
      lag_at_s < 1.0 && lag < input ? "KEPT UP in real time" : "did NOT keep up");
  printLatency("realtime:", all);
  const bool same = compareCounts(cluster, rt);
  std::printf("realtime: samples lost or doubled: %s\n", same ? "none" : "YES (above)");
  return same &&
         std::all_of(rt.begin(), rt.end(), [](const RealTimeBench& r) { return r.imu > 0; });
}

}  // namespace

int main(int argc, char** argv) {
  int benches = 20;
  double seconds = 30.0;
  double backlog_s = 20.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--benches") benches = std::max(1, std::atoi(argv[i + 1]));
    if (a == "--seconds") seconds = std::max(1.0, std::atof(argv[i + 1]));
    if (a == "--backlog-s") backlog_s = std::max(1.0, std::atof(argv[i + 1]));
  }
  const char* tmp = std::getenv("TMPDIR");
  std::string root = std::string(tmp != nullptr ? tmp : "/tmp") + "/imubench-lab-bench-XXXXXX";
  if (::mkdtemp(root.data()) == nullptr) return 1;
  ::chmod(root.c_str(), 0755);  // as root the cluster runs as postgres (tools/lab-db.sh)
  bool ok = false;
  {
    Cluster cluster(root);
    if (!cluster.ok()) {
      std::cerr << "cannot start a PostgreSQL cluster: see " << root << "/init.log\n";
      return 1;
    }
    std::printf(
        "target: %.0f benches x (2000 IMU + 100 table + 1 chamber rows/s) = %.0f rows/s "
        "into one local PostgreSQL\n",
        kTargetBenches, kTargetRowsPerS);
    ok = itemsPhase(cluster, root) && backlogPhase(cluster, root, 1, 120.0, "samples") &&
         backlogPhase(cluster, root, benches, backlog_s, "backlog") &&
         loopPhase(cluster, root, 20.0, false) && loopPhase(cluster, root, 20.0, true) &&
         baselinePhase(root, benches, seconds) && realTimePhase(cluster, root, benches, seconds);
  }
  std::error_code ec;
  fs::remove_all(root, ec);
  return ok ? 0 : 1;
}
