// Free (unaided) navigation of an IMU sample sequence from a known initial state, reporting
// the navigation errors of a bench: velocity against a reference velocity (zero for a
// bench) and horizontal displacement from the start point, decimated to an output interval.
//
// Two forms over the same step:
//   navigateFree(initial, samples, opt)  - a whole recording (the seed's validation
//                                           experiment, `imubench nav DIR`);
//   FreeNavigator                        - fed sample by sample (the daemon, online).
//
// Displacement is measured in the local level frame at the start point:
//   d_E = (lon - lon0) (R_N(lat0) + h0) cos(lat0),   d_N = (lat - lat0) (R_M(lat0) + h0).
//
// Input checks (external data never crashes): time stamps must increase; an interval longer
// than max_interval_ratio x the running mean interval is a gap (lost samples): it stops
// navigation (GapPolicy::kStop, default) or is bridged and counted (kBridge, for the online
// daemon); non-finite increments stop navigation. The error names the sample time and why.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "nav/imu_sample.h"
#include "nav/strapdown.h"

namespace imubench::nav {

// What a gap (lost samples) does.
enum class GapPolicy {
  kStop,    // stop with FreeNavStatus::kGap: the lost rotation would silently corrupt a run
  kBridge,  // integrate the missing time holding the next sample's rates, count it, go on
};

struct FreeNavOptions {
  // Mechanization settings (coning/sculling, vertical channel, site gravity).
  MechOptions mech;
  // Spacing of the output series, s. 1 s resolves the Schuler oscillation (84 min) and
  // the seed's 15-min holds with a small file; the first point is the initial state.
  double output_interval_s = 1.0;
  // Reference velocity in L (ENU), m/s, subtracted to give velocity errors. A bench is at
  // rest on the Earth: zero.
  Vec3 reference_v_L = Vec3::Zero();
  // An interval longer than this multiple of the running mean interval is treated as lost
  // samples. 1.5 lets normal time-stamp jitter through (real recordings show +-10 %) and
  // catches one lost sample.
  double max_interval_ratio = 1.5;
  // Offline analysis wants to know (stop); an online navigator must keep going (bridge).
  GapPolicy gap_policy = GapPolicy::kStop;

  bool IsValid(std::string* why) const;
};

// One output point.
struct NavErrorPoint {
  double t = 0.0;                  // s
  double v_E_err = 0.0;            // m/s, v_E - reference v_E
  double v_N_err = 0.0;            // m/s
  double v_U_err = 0.0;            // m/s (zero in hold-height mode)
  double d_E_m = 0.0;              // East displacement from the start point, m
  double d_N_m = 0.0;              // North displacement from the start point, m
  Quat q_BtoL = Quat::Identity();  // attitude
};

enum class FreeNavStatus {
  kOk,
  kInvalidOptions,
  kBadInitialState,  // non-finite or |lat| >= 90 deg
  kBadTimestamps,    // time not increasing (or first sample not after the initial state)
  kGap,              // interval > max_interval_ratio x mean interval (GapPolicy::kStop)
  kNonFinite,        // NaN/Inf increments
};

const char* freeNavStatusName(FreeNavStatus s);

struct FreeNavResult {
  FreeNavStatus status = FreeNavStatus::kOk;
  std::string message;                // why, when status != kOk
  std::vector<NavErrorPoint> series;  // decimated; valid up to where navigation stopped
  NavState final_state;               // state after the last accepted sample
  std::size_t samples_used = 0;
  std::size_t gaps_bridged = 0;  // GapPolicy::kBridge only

  bool ok() const { return status == FreeNavStatus::kOk; }
};

// The streaming navigator.
class FreeNavigator {
 public:
  // initial.t is the START of the first sample's interval. Invalid options or state are
  // reported by status() and by every feed().
  FreeNavigator(const NavState& initial, const FreeNavOptions& opt);

  struct FeedResult {
    FreeNavStatus status = FreeNavStatus::kOk;
    std::string message;                  // why, when rejected (the state is unchanged then)
    std::optional<NavErrorPoint> output;  // set when an output time was reached
    bool gap_bridged = false;             // kBridge: a gap before this sample was bridged
  };
  FeedResult feed(const ImuSample& sample);

  FreeNavStatus status() const { return init_status_; }
  const std::string& statusMessage() const { return init_message_; }
  const NavState& state() const { return state_; }
  std::size_t gapsBridged() const { return gaps_bridged_; }
  NavErrorPoint current() const;       // errors at the current state
  NavErrorPoint initialPoint() const;  // the first output point (t0, zero displacement)

 private:
  // Errors of a state against the reference velocity and the initial position.
  NavErrorPoint pointOf(const NavState& s) const;

  FreeNavOptions opt_;
  NavState state_;
  NavState initial_;
  ImuSample prev_sample_;    // zero increments until the first sample
  double nominal_dt_ = 0.0;  // running mean sample interval (0 before the first sample)
  std::size_t gaps_bridged_ = 0;
  double next_output_t_ = 0.0;
  double rm_h0_ = 0.0;
  double rn_cos_h0_ = 0.0;
  FreeNavStatus init_status_ = FreeNavStatus::kOk;
  std::string init_message_;
};

// Navigates the whole span. The series starts with the initial point.
FreeNavResult navigateFree(const NavState& initial, std::span<const ImuSample> samples,
                           const FreeNavOptions& opt);

// Start of the first sample's interval assuming the rate of the first two samples
// (samples[0].t - (samples[1].t - samples[0].t)); NaN for fewer than two samples.
double firstIntervalStart(std::span<const ImuSample> samples);

}  // namespace imubench::nav
