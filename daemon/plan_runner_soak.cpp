// The automatic soak's judgement (daemon/plan_runner.h): the temperature's slope over a window
// (SlopeWindow) and PlanRunner::autoSoakOver, which ends a soak step settled or timed out.

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <optional>
#include <string>

#include "daemon/plan_runner.h"

namespace imubench::daemon {

void SlopeWindow::add(double t_s, double temp_c) {
  if (!t_.empty() && !(t_s - t_.back() >= window_s_ / kMaxSamples)) return;
  t_.push_back(t_s);
  y_.push_back(temp_c);
  std::size_t drop = 0;
  while (drop < t_.size() && t_s - t_[drop] > window_s_) ++drop;
  t_.erase(t_.begin(), t_.begin() + static_cast<std::ptrdiff_t>(drop));
  y_.erase(y_.begin(), y_.begin() + static_cast<std::ptrdiff_t>(drop));
}

std::optional<double> SlopeWindow::slope() const {
  if (t_.size() < 3 || t_.back() - t_.front() < 0.9 * window_s_) return std::nullopt;
  const double n = static_cast<double>(t_.size());
  double mt = 0.0, my = 0.0;
  for (std::size_t i = 0; i < t_.size(); ++i) mt += t_[i], my += y_[i];
  mt /= n;
  my /= n;
  double sty = 0.0, stt = 0.0;
  for (std::size_t i = 0; i < t_.size(); ++i) {
    sty += (t_[i] - mt) * (y_[i] - my);
    stt += (t_[i] - mt) * (t_[i] - mt);
  }
  if (!(stt > 0.0)) return std::nullopt;
  return sty / stt;
}

double SlopeWindow::centerTime() const {
  return t_.empty() ? 0.0 : 0.5 * (t_.front() + t_.back());
}

namespace {
std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}
}  // namespace

// The IMU's temperature rate (else the chamber's, said so in the event) below settle_rate for
// settle_hold, measured from the end of the program's ramp; at max_soak the step ends flagged.
bool PlanRunner::autoSoakOver(const BenchObservation& obs, double waited_s) {
  const RunStep& s = steps_[step_];
  const double t = obs.plan_time_s.value_or(obs.now_s);
  const bool chamber = !obs.imu_temp_c && obs.chamber_temp_c;
  const std::optional<double> temp = chamber ? obs.chamber_temp_c : obs.imu_temp_c;
  if (temp && waited_s >= s.ramp_s) {
    if (soak_.from_chamber != chamber) {  // another source: start the window afresh
      soak_.window.clear();
      soak_.below_since_s.reset();
      soak_.from_chamber = chamber;
    }
    soak_.used_chamber = soak_.used_chamber || chamber;
    soak_.window.add(t, *temp);
    if (const auto slope = soak_.window.slope()) {
      if (std::abs(*slope) >= s.settle_rate_c_per_s) {
        soak_.below_since_s.reset();
      } else if (!soak_.below_since_s) {
        soak_.below_since_s = soak_.window.centerTime();
      }
    }
  }
  const std::string source =
      !soak_.from_chamber  ? "no temperature (neither the IMU's frames nor the chamber give one)"
      : soak_.used_chamber ? "the chamber temperature (no IMU temperature in its frames)"
                           : "the IMU temperature";
  const std::string criterion = " (rate below " + fmt(s.settle_rate_c_per_s * 60.0) +
                                " degC/min for " + fmt(s.settle_hold_s) + " s, measured on " +
                                source + "; predicted " + fmt(s.planned_s) + " s)";
  if (soak_.below_since_s && t - *soak_.below_since_s >= s.settle_hold_s) {
    emit(
        RunnerEvent::Kind::kSoakSettled, obs.now_s,
        "soak settled at " + fmt(s.setpoint_c) + " degC after " + fmt(waited_s) + " s" + criterion);
    return true;
  }
  if (waited_s >= s.max_soak_s) {
    emit(RunnerEvent::Kind::kSoakTimeout, obs.now_s,
         "soak_timeout: step '" + s.label + "' not settled at " + fmt(s.setpoint_c) +
             " degC after max_soak " + fmt(s.max_soak_s) + " s" + criterion +
             ": the plan goes on, this temperature point is flagged");
    return true;
  }
  return false;
}

}  // namespace imubench::daemon
