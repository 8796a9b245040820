// Internals shared by the parts of BenchDaemon (daemon/bench_daemon.h): LoadedPlan, the run in
// progress (BenchDaemon::ActiveRun) and a few helpers. Not a public API: only
// daemon/bench_daemon.cpp and daemon/bench_daemon_*.cpp include it. Which part holds what is
// listed at the top of daemon/bench_daemon.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/bench_daemon.h"
#include "daemon/imu_clock.h"
#include "plans/plan.h"

namespace imubench::daemon {

// A plan ready to run on this bench (loadPlan).
struct LoadedPlan {
  plans::Plan plan;
  std::string text;
  calib::Motion motion;
};

namespace bench_daemon_internal {

// A quantity not known (yet).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Now on the wall clock (drivers::unixTimeS), s since the Unix epoch.
double unixNow();

// errno in words: strerror_r (GNU: returns the text, in buf or static), not strerror, which
// may share its buffer with the off-loop threads.
std::string errnoWords(int err);

// A plan's text (sent by the client, or read from the plan library) parsed, validated, and
// checked against this bench (table kind, limits). name is what diagnostics call it. nullopt
// with the diagnostics text when refused.
std::optional<LoadedPlan> loadPlan(const std::string& name, const std::string& text,
                                   const BenchConfig& bench, std::string* why);

}  // namespace bench_daemon_internal

// For ActiveRun below (this header is included only by the parts of BenchDaemon).
using bench_daemon_internal::kNaN;

// The run in progress: its runner, its writer, and the open segment.
struct BenchDaemon::ActiveRun {
  std::int64_t id = 0;
  std::string plan_name;
  std::unique_ptr<PlanRunner> runner;
  std::unique_ptr<RunWriter> writer;
  std::optional<OnlineSetup> calibration;  // the plan names a calibration
  std::unique_ptr<OnlineEngine> engine;    // with it
  std::optional<double> segment_t0;        // IMU time the current step's command went out
  int last_stored_step = -1;               // the step of the newest stored segment
  std::optional<double> last_sample_t;     // the newest stored IMU sample (gaps: onRecordingGap)
  bool imu_restarted = false;              // the decoder saw a restart since the last batch
  // The progress shown (status, progress events): never below what was shown before in this
  // run, though the runner's planned-time figure drops when a step re-runs after a pause.
  double progress_shown = 0.0;
  double shownProgress() {
    progress_shown = std::max(progress_shown, runner->progress());
    return progress_shown;
  }
  // A finished step whose segment waits for the first IMU sample received after the table
  // reading that ended it (after_unix_s, CLOCK_REALTIME like the frames' kernel time stamps).
  struct ClosingStep {
    int step = -1;
    std::string label;
    double after_unix_s = 0.0;
    std::optional<int> next_step;  // started meanwhile: begins where this one ends
    // Its step_finished event, stored only after the segment (the crash-resume checkpoint
    // must never name a step whose segment a kill -9 could still lose).
    RunEvent finished;
  };
  std::optional<ClosingStep> closing;
  // The IMU's rate, low-pass filtered over kStillTauS of sample time: the table is still when
  // it is below kStillRateRadps (far above the Earth rate and a navigation-grade gyro's
  // averaged noise, far below any plan's motion).
  static constexpr double kStillTauS = 0.1;
  static constexpr double kStillRateRadps = 0.1 * kDegToRad;
  Vec3 rate_filtered = Vec3::Zero();
  std::optional<double> rate_last_t;
  void trackStillness(const nav::ImuSample& s) {
    if (rate_last_t && s.t > *rate_last_t) {
      const double dt = s.t - *rate_last_t;
      rate_filtered += (s.dtheta / dt - rate_filtered) * std::min(1.0, dt / kStillTauS);
    }
    rate_last_t = s.t;
  }
  bool imuStill() const { return rate_filtered.norm() < kStillRateRadps; }
  double poll_unix_s = 0.0;  // when the newest table reading was requested
  std::optional<double> last_table_t;
  // How the newest stored table reading was read: a gap in the table readings is judged on it
  // (BenchConfig::table_reading_gap_s). Reset by a gap of the IMU stream, which holds the readings
  // back too and is handled as such.
  std::optional<TableReadTiming> last_table_read;
  // The poll durations of the newest stored readings (at most kPollHistory): their median is
  // the link's cadence. Not the newest poll's own duration: a loop held up inside a poll (the
  // polls are most of its time on a slow link) made that poll long, and it is the gap.
  static constexpr std::size_t kPollHistory = 9;
  std::deque<double> poll_durations_s;
  double typicalPollS(double fallback_s) const {
    if (poll_durations_s.empty()) return fallback_s;
    std::vector<double> v(poll_durations_s.begin(), poll_durations_s.end());
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  }
  void addPollDuration(double s) {
    poll_durations_s.push_back(s);
    if (poll_durations_s.size() > kPollHistory) poll_durations_s.pop_front();
  }
  // A table reading waits for its IMU time. The controller sampled each axis' encoder
  // between the request and the reply that read it (drivers::TableAxisReading::read_unix_s,
  // CLOCK_REALTIME like the frames' kernel receive times); `clock` maps those instants onto
  // the recording's clock (the IMU's sample times), and the axes are brought to their mean
  // instant with their rates. (Stamping the reading with the newest sample before the request
  // lags the table by the round trips and the frames queued meanwhile: the analysis then finds
  // a time delay that is the daemon's own.) The anchors are the last samples of the bursts the
  // IMU sends (frames received within kBurstGapS of each other): a sender that batches its
  // samples sends a burst when its newest sample is due, so that sample, not the burst's
  // first, stands at the receive time; an IMU that sends each sample alone makes every sample
  // an anchor. Until the clock map answers: interpolation between the anchors around the
  // reading's instant; frames without a receive time: the first sample after the reading.
  static constexpr double kBurstGapS = 1e-4;
  struct PendingTable {
    std::array<double, 3> read_unix_s{};        // per axis; 0 when the driver gives none
    std::array<double, 3> rate{};               // rad/s, per axis
    io::TableSample sample;                     // angles set, t to be found
    TableReadTiming read{0.0, kNaN, 0.0, 0.0};  // at_unix_s: the axes' mean read time
  };
  std::optional<PendingTable> pending_table;
  std::optional<double> last_rx_unix_s, last_rx_t;  // newest sample with a receive time
  ImuClockMap clock;
  // The encoder angles as stored: continuous across the controller's +-180 deg wrap (the
  // recording's convention, as the plan writes them), so a three-turn rate run reads 1080 deg.
  // Unwrapped from the previous reading: the table turns far less than half a turn between
  // two polls.
  std::array<std::optional<double>, 3> last_angle;
  double unwrapped(std::size_t axis, double read_rad) {
    std::optional<double>& last = last_angle[axis];
    const double a = last ? *last + std::remainder(read_rad - *last, 2.0 * kPi) : read_rad;
    last = a;
    return a;
  }  // The table reading of obs waiting for its IMU time; polled: the instant of the whole read,
  // for axes the driver gives no read time.
  PendingTable reading(const BenchObservation& obs, double polled, double poll_duration_s) {
    PendingTable p;
    double sum = 0.0;
    std::size_t stamped = 0;
    for (std::size_t a = 0; a < obs.angles.size() && a < 3; ++a) {
      p.sample.angles_deg[a] = unwrapped(a, obs.angles[a]) * kRadToDeg;
      p.rate[a] = a < obs.rates.size() ? obs.rates[a] : 0.0;
      p.read_unix_s[a] = a < obs.angles_unix_s.size() ? obs.angles_unix_s[a] : 0.0;
      if (p.read_unix_s[a] > 0.0) sum += p.read_unix_s[a], ++stamped;
      const double rt = a < obs.angles_round_trip_s.size() ? obs.angles_round_trip_s[a] : 0.0;
      double& longest = p.read.round_trip_s;
      if (rt > 0.0) longest = std::isnan(longest) ? rt : std::max(longest, rt);
    }
    p.read.poll_duration_s = poll_duration_s;
    p.read.busy_s = obs.busy_s;
    p.read.at_unix_s = stamped ? sum / static_cast<double>(stamped) : polled;
    for (double& r : p.read_unix_s) {
      if (!(r > 0.0)) r = p.read.at_unix_s;
    }
    return p;
  }

  std::optional<double> last_chamber_t;
};

}  // namespace imubench::daemon
