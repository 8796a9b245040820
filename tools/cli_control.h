// The operator's view of a run followed over the control socket (imubench watch / start
// --watch): what status replies and events say, folded into one state and shown as a
// one-line progress bar. Pure, so tests feed it events; the field names assumed are listed at
// the top of cli_control.cpp.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace imubench::tools {

struct WatchState {
  std::string state;  // "running", "paused", "finished", "faulted", ... ("" unknown)
  std::string exit;   // how a finished run ended: "completed", "aborted", "emergency_stop"
  std::optional<long long> run;
  std::string plan;
  std::optional<long long> step;   // index of the current step (as the daemon numbers them)
  std::optional<long long> count;  // number of steps
  std::string label;               // current step's label
  std::optional<double> progress;  // 0..1
  std::optional<double> eta_s;

  // The run reached an end state: finished (any exit), faulted, aborted or interrupted.
  bool ended() const;
  // Ended with exit completed (a "finished" without an exit field counts as completed).
  bool completed() const;
};

// Folds a status reply's result into s (fields that are absent leave s as it was).
void applyStatus(WatchState& s, const nlohmann::json& result);
// Folds an event into s. Lines meant for the operator beyond the bar (alarms, estimates, log
// messages) are appended to notes. Once s.ended(), its state and exit no longer change.
void applyEvent(WatchState& s, const nlohmann::json& event, std::vector<std::string>* notes);

// "[#######.............]  31%  ETA 13:32  step 3/45 run01_x_p1  running", at most width
// columns (width <= 0: no limit).
std::string formatProgressLine(const WatchState& s, int width);
// "run 12 completed", "run 12 finished: aborted", "run 12 faulted".
std::string formatEndLine(const WatchState& s);
// "1:02:03" or "13:32".
std::string formatDuration(double seconds);

}  // namespace imubench::tools
