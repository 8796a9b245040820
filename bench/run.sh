#!/usr/bin/env bash
# Runs every benchmark in one go and prints each against its target as a ratio, so numbers
# taken on a noisy machine are compared within one run (README "Performance").
# Usage: bench/run.sh [BUILD_DIR]   (default: build; build it first: cmake --build build)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
run() {  # name, binary, extra args...
  local name=$1 bin=$2
  shift 2
  echo "== $name =="
  if [[ ! -x $bin ]]; then
    echo "bench/run.sh: $bin is not built" >&2
    return 1
  fi
  "$bin" "$@"
}
run "strapdown update (target >= 5 M samples/s, counter x_5M_target)" \
  "$build/bench/nav/imubench_nav_bench"
run "simulator (target >= 2 M samples/s)" "$build/bench/calib/imubench_calib_bench"
run "indirect calibration of a 2 kHz 12-run recording (target < 10 s)" \
  "$build/bench/calibration/imubench_bench_indirect_calibration"
run "imubench explain of a 2 kHz 12-run recording: baseline calibration + analysis (target < 10 s, counter fraction_of_10s_target; baseline_s / bins_s / analysis_s / json_s: where the time goes)" \
  "$build/bench/calibration/imubench_bench_explain"
run "reading a 1 h, 2 kHz imubench-csv/1 recording (target < 10 s)" \
  "$build/bench/daemon/imubench_daemon_bench"
run "SQLite store: appending a 2 kHz IMU + 100 Hz table run (target >= 10x real time, counter x_realtime)" \
  "$build/bench/daemon/imubench_store_bench"
run "online engine on the loop per IMU sample at 2 kHz (target < 5 % of one core, counter x_target)" \
  "$build/bench/daemon/imubench_online_engine_bench"
run "thermal calibration over -40..+60 degC: continuous-ramp vs soak-point plan (target: ramp chamber time <= 0.5 x soak, both within 2x noise floor and 5 % bias tempco; exit 1 when not)" \
  "$build/bench/calibration/imubench_bench_thermal" || true
"$here/bench/can_bench.sh" "$build"
