#!/usr/bin/env bash
# The demo's bench (tools/demo.sh runs it where vcan0 exists): the virtual bench and imubenchd
# in a scratch directory, the direct plan and the 12-run plan through the imubench CLI, then the
# stored results against the truth. Every process it starts is stopped on exit.
# Usage: demo_bench.sh SOURCE_DIR [OUT_DIR]
set -euo pipefail
SRC=$1
OUT=${2:-}
B=$SRC/build
DEV=$SRC/drivers/devices
SCALE=${DEMO_TIME_SCALE:-20}
TRUTH=$SRC/tests/tools/data/truth_nav_grade.json
W=$(mktemp -d)
export IMUBENCH_SOCKET=$W/control.sock IMUBENCH_DB=$W/imubench.db
cleanup() {
  [[ -n ${DPID:-} ]] && kill "$DPID" 2>/dev/null && wait "$DPID" 2>/dev/null
  [[ -n ${VPID:-} ]] && kill "$VPID" 2>/dev/null && wait "$VPID" 2>/dev/null
  rm -rf "$W"
}
trap cleanup EXIT
die() {
  echo "demo: $*" >&2
  tail -5 "$W/vb.out" "$W/d.out" >&2 || true
  exit 1
}

# The IMU at 200 Hz (the bundled CAN FD layout with a 5 ms period): light enough to run the
# bench 20 times faster than the wall clock.
sed 's/^sample_period = "1 ms"/sample_period = "5 ms"/' "$DEV/imus/navgrade_fd.toml" >"$W/imu.toml"
# The bundled plans with the calibration they feed.
sed 's/^name = "direct_two_axis"/&\ncalibration = "direct"/' \
  "$SRC/plans/library/direct_two_axis.toml" >"$W/direct_two_axis.toml"
sed 's/^name = "two_axis_12run"/&\ncalibration = "pipeline"\ndirect_plan = "direct_two_axis"/' \
  "$SRC/plans/library/two_axis_12run.toml" >"$W/two_axis_12run.toml"
cat >"$W/bench.toml" <<TOML
[bench]
name = "demo"
storage = "$W/imubench.db"
control_socket = "$W/control.sock"
[site]
latitude = "55.7558 deg"
height = "150 m"
[table]
device = "$DEV/tables/imubench-ref-2axis-tcp.toml"
port = 1502
max_rate = "30 deg/s"
max_accel = "10 deg/s^2"
[chamber]
device = "$DEV/chambers/watlow-f4-style.toml"
port = 1503
[imu]
layout = "$W/imu.toml"
interface = "vcan0"
serial = "DEMO-0001"
TOML
cat "$SRC/tools/demo_bench_limits.toml" >>"$W/bench.toml"

echo "== virtual bench (time x$SCALE, truth $TRUTH) and imubenchd on vcan0"
"$B/tools/imubench-virtual-bench" --table "$DEV/tables/imubench-ref-2axis-tcp.toml" \
  --chamber "$DEV/chambers/watlow-f4-style.toml" --imu "$W/imu.toml" --can vcan0 \
  --time-scale "$SCALE" --truth "$TRUTH" --noise nav-grade --seed 3 >"$W/vb.out" 2>&1 &
VPID=$!
for _ in $(seq 300); do grep -q '^ready' "$W/vb.out" && break; sleep 0.1; done
grep -q '^ready' "$W/vb.out" || die "virtual bench not ready"
"$B/daemon/imubenchd" --bench "$W/bench.toml" --stderr >"$W/d.out" 2>&1 &
DPID=$!
for _ in $(seq 300); do [[ -S $W/control.sock ]] && break; sleep 0.1; done
[[ -S $W/control.sock ]] || die "imubenchd did not start"

# Runs a plan with a live progress bar and the estimates; prints its run id last.
run_plan() {
  echo "== $1" >&2
  "$B/tools/imubench" start "$W/$1.toml" --watch | tee "$W/$1.out" >&2
  sed -n 's/^started run \([0-9]*\).*/\1/p' "$W/$1.out" | head -n1
}
wait_results() {
  for _ in $(seq 600); do
    # 0 PASS, 4 FAIL, 5 undetermined: results are stored; 1: not yet.
    local rc=0
    "$B/tools/imubench" results "$1" >/dev/null 2>&1 || rc=$?
    [[ $rc == 0 || $rc == 4 || $rc == 5 ]] && return 0
    sleep 0.5
  done
  die "no results for run $1"
}
direct=$(run_plan direct_two_axis)
wait_results "$direct"
nav=$(run_plan two_axis_12run)
wait_results "$nav"
echo "== stored calibration of run $nav (direct part: run $direct) against the virtual bench's truth"
args=(results "$nav" --truth "$TRUTH")
[[ -n $OUT ]] && args+=(--coefficients "$OUT/coefficients.json")
status=0
"$B/tools/imubench" "${args[@]}" || status=$?
if [[ -n $OUT ]]; then
  cp "$TRUTH" "$OUT/truth.json"
  echo "written: $OUT/coefficients.json $OUT/truth.json"
fi
echo "== IMU DEMO-0001 history"
"$B/tools/imubench" results --serial DEMO-0001
exit "$status"
