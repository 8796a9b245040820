// The calibration engine online during a run. On the event loop's thread, as frames arrive:
// the current step's statistics are updated in O(1) per sample (hold: mean and per-sample
// noise of specific force and rate; run: the summed increments), and the samples are kept in
// per-step chunks that are sealed (immutable, shared) when the step ends. After every step
// that makes a new estimate possible — a hold or a rotation of a direct plan, a pair of
// rotations of a navigation plan — the calibration over the sealed chunks runs OFF the loop
// (daemon/off_loop.h) through the library calibrators (daemon/run_calibration.h), and its
// result is published on the loop as an `estimate` event: coefficients with sigmas and the
// parameters still unobservable. At most one estimate is computed at a time; steps that end
// meanwhile are folded into the next one (the newest data win, nothing queues up).
//
// The full calibration at the end of a plan reads the stored run instead (finalCalibration):
// what a resumed or restarted run has stored counts, not only what this process saw.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "calib/explain/explain.h"
#include "calib/explain/explain_propose.h"
#include "calib/model/motion.h"
#include "daemon/bench_file.h"
#include "daemon/off_loop.h"
#include "daemon/run_calibration.h"
#include "io/recording.h"
#include "nav/imu_sample.h"
#include "plans/plan.h"

namespace imubench::daemon {

// Running statistics of one step (Welford's mean and variance, summed increments).
struct StepStats {
  int step = -1;
  calib::SegmentKind kind = calib::SegmentKind::kStatic;
  std::size_t samples = 0;
  double t0 = 0.0;  // first and last sample time in the step
  double t1 = 0.0;
  Eigen::Vector3d f_mean = Eigen::Vector3d::Zero();  // mean specific force, m/s^2
  Eigen::Vector3d w_mean = Eigen::Vector3d::Zero();  // mean rate, rad/s
  Eigen::Vector3d f_m2 = Eigen::Vector3d::Zero();    // sums of squared deviations
  Eigen::Vector3d w_m2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();  // summed increments, rad
  Eigen::Vector3d dvel = Eigen::Vector3d::Zero();    // m/s

  // One sample whose interval lasted dt (> 0).
  void add(const nav::ImuSample& s, double dt);
  // Holds: means, per-sample noise (1 sigma) in m/s^2 and deg/h; runs: turned angle (deg)
  // and velocity increment.
  nlohmann::json toJson() const;
};

// What a run's calibration needs besides its samples.
struct OnlineSetup {
  std::int64_t run_id = 0;
  plans::CalibrationMethod method = plans::CalibrationMethod::kNone;
  std::optional<std::int64_t> direct_run;  // kPipeline: the direct plan's run
  std::string db_path;                     // the store (its own connection, off the loop)
  io::Recording meta;                      // the run's meta data (site, table, serial)
  std::vector<AcceptanceLimit> acceptance;
  // The bench file's [table] errors: known to every calibration of the run (calibrateRun).
  std::optional<calib::TableErrors> known_table_errors;
  // The end-of-plan missing-physics analysis (daemon/run_explain.h): calib's defaults, which
  // its concealed-effect suite tunes; a field so a bench (or a test) can change them.
  calib::ExplainOptions explain;
  // The follow-up proposal's search within the bench's limits (daemon/follow_up.h); unset: the
  // bench's [explain] follow_up is "off".
  std::optional<calib::ProposeOptions> follow_up;
};

class OnlineEngine {
 public:
  // Runs on the loop: an `estimate` event's fields (run, step, label, method, ok,
  // parameters, unobservable, summary).
  using Publish = std::function<void(const nlohmann::json& fields)>;

  // worker outlives the engine (jobs in flight when it is destroyed are dropped).
  OnlineEngine(OnlineSetup setup, OffLoop* worker, Publish publish);
  ~OnlineEngine();
  OnlineEngine(const OnlineEngine&) = delete;
  OnlineEngine& operator=(const OnlineEngine&) = delete;

  // The loop's hot path: O(1) per sample.
  void addImu(std::span<const nav::ImuSample> samples);
  void addTable(const io::TableSample& sample);
  void stepStarted(int step, calib::SegmentKind kind);
  // The step's segment as stored (nullopt: none, e.g. recording off or too short). Returns
  // the step's statistics; starts an estimate when this step makes a new one possible.
  nlohmann::json stepFinished(const std::optional<calib::Segment>& segment,
                              const std::string& label);

  int estimatesPublished() const { return published_; }

 private:
  // The sealed part of the run: shared, immutable chunks (a job copies this value, not the
  // samples).
  struct Chunks {
    std::vector<std::shared_ptr<const nav::ImuSamples>> imu;
    std::vector<std::shared_ptr<const std::vector<io::TableSample>>> table;
    std::vector<calib::Segment> segments;
  };
  // The pipeline's direct run, loaded by the first estimate that needs it (estimates run one
  // at a time, so only one job touches it at once).
  struct Reference {
    bool tried = false;
    std::optional<io::Recording> recording;
    std::string error;
  };
  void sealChunk();
  bool makesEstimatePossible(const calib::Segment& segment);
  void startEstimate();
  void onEstimate(const RunCalibration& c, int step, const std::string& label);

  OnlineSetup setup_;
  OffLoop* worker_;
  Publish publish_;
  Chunks sealed_;  // copied into each job
  std::shared_ptr<Reference> reference_;
  std::shared_ptr<nav::ImuSamples> imu_;  // the open chunk
  std::vector<io::TableSample> table_;    // the open chunk's table samples
  std::optional<StepStats> stats_;        // the current step's
  std::optional<double> last_t_;          // the newest IMU sample time
  int rotations_done_ = 0;
  int rotations_estimated_ = 0;  // rotations_done_ at the last navigation estimate
  bool in_flight_ = false;
  bool pending_ = false;  // a step ended while an estimate was running
  int last_step_ = -1;
  std::string last_label_;
  int published_ = 0;
  std::shared_ptr<bool> alive_;  // false once destroyed: late results are dropped
};

// The recording as the calibrations and the analysis see it: every stored sample, and the
// segments no gap in the IMU stream touches (calib/static_detection.h checkIncrements refuses
// a gap, longer than its max_gap_factor median steps, inside a segment or with a rotation as
// its nearest segment on either side). A segment spanning a gap and a rotation next to one are
// left out, each named in `notes` (when not null); the gap itself and the samples around it
// stay. The daemon stores no such segment (it re-runs steps after a gap: plan_runner.h
// gapRestart); this keeps a run stored otherwise (before that rule, a soak spanning an IMU
// restart) calibratable from its complete segments. Pure.
io::Recording completeSegmentsOnly(io::Recording rec, std::vector<std::string>* notes);

// The full calibration of a completed run from the store (runs on a worker thread): loads the
// run (and the pipeline's direct run) on its own connection, calibrates, judges. Its result:
// the results to store ("coefficients": interchange coefficient JSON; "report"; "verdict";
// "explain": the missing-physics analysis from the final coefficients, daemon/run_explain.h)
// with the run's IMU serial and mean temperature, or an error naming why none could be made.
// A failed analysis never fails the run: no "explain" result, its reason in explain_error and
// as a note of the verdict.
struct FinalCalibration {
  // Ok: the run could be read (the calibration itself may still have failed: `calibrated`).
  Status status = Status::Error("not read");
  std::string imu_serial;
  double temperature_c = 0.0;
  bool calibrated = false;
  nlohmann::json coefficients;  // when calibrated
  nlohmann::json report;
  nlohmann::json verdict;
  std::optional<nlohmann::json> explain;    // imubench-explain/1, when the analysis ran
  std::string explain_summary;              // when it ran: one line (accepted effects, RMS)
  std::string explain_error;                // when it did not: why
  std::optional<nlohmann::json> follow_up;  // daemon/follow_up.h, when proposed or refused
};
FinalCalibration finalCalibration(const OnlineSetup& setup);

}  // namespace imubench::daemon
