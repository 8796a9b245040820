#!/usr/bin/env bash
# Shared harness of the daemon's end-to-end tests (sourced, run under tools/vcan-run.sh so
# vcan0 exists): a scratch directory, the virtual bench, imubenchd with a bench file pointing
# at it, and cleanup. Every process it starts is stopped on exit.
#
#   source "$SRC/tests/daemon/e2e/lib.sh"
#   e2e_init VB DAEMON CLI SRC         # sets W (scratch dir), DEV (device files), trap cleanup
#   e2e_bench_file [EXTRA_TOML]        # writes $W/bench.toml (2-axis TCP table, chamber, IMU);
#                                      #   $E2E_CHAMBER_EXTRA: more lines for [chamber]
#                                      #   $E2E_BENCH_EXTRA: more lines for [bench]
#   e2e_clock_ratio SCALE              # prints [imu] max_clock_ratio for a virtual bench at
#                                      #   --time-scale SCALE (its IMU's clock runs SCALE x)
#   e2e_start_vb [ARGS...]             # virtual bench with the same devices; waits for "ready"
#   e2e_start_daemon                   # imubenchd on $W/bench.toml; waits for the socket
#   e2e_start SCALE [VB_ARGS...]       # e2e_start_vb --time-scale SCALE VB_ARGS, e2e_start_daemon
#                                      #   (and e2e_bench_file first when there is no bench file)
#   e2e_plan_head NAME [DESCRIPTION]   # prints a plan's [plan] and two-axis [table] sections
#   e2e_plan_chamber MIN MAX [INITIAL] # prints its [chamber] section (degC, 5 degC/min)
#   e2e_hold LABEL DURATION            # prints a hold step
#   e2e_rotate LABEL AXIS ANGLE DIR    # prints a rotate step at 10 deg/s, 5 deg/s^2
#   $E2E_SLOW_IMU                      # bench-file lines (e2e_bench_file "$E2E_SLOW_IMU"): a
#                                      #   2 s imu_timeout for a test about another fault
#   $E2E_WATCHDOG_TIMEOUT              # the virtual table's host-watchdog timeout, s (default
#                                      #   2: a stalled machine must not open the interlock in a
#                                      #   test about something else; host_watchdog.sh: 0.5)
#   $E2E_TABLE_EXTRA                   # lines for the bench file's [table] (e.g. errors = FILE)
#   $E2E_TABLE_READING_GAP             # the bench file's [table] reading_gap (default 3 s: a
#                                      #   loaded user-mode Linux holds the loop up for a second
#                                      #   and more; table_gap.sh and table_latency.sh: 0.2 s,
#                                      #   the daemon's default)
#   e2e_stop_daemon                    # SIGTERM, checks the exit status
#   e2e_truth_targets OUT              # OUT (`imubench results RUN --truth T`) meets the targets:
#                                      #   scale/misalignment/table rows within 3 arcsec / 10 ppm,
#                                      #   at most one bias outside 2 sigma, none beyond 3 sigma
#   e2e_py SCRIPT [ARGS...]            # python3 with tests/daemon/e2e on the path (e2e_client)
#   fail MESSAGE                       # prints the tails of the logs and exits 1
# The bench file uses limits the bundled virtual bench has (30 deg/s, 10 deg/s^2), so the
# e2e plans must stay within them.

e2e_init() {
  VB=$1
  DAEMON=$2
  CLI=$3
  SRC=$4
  DEV=$SRC/drivers/devices
  W=$(mktemp -d)
  export IMUBENCH_SOCKET=$W/control.sock
  trap e2e_cleanup EXIT
}

e2e_cleanup() {
  [[ -n ${DPID:-} ]] && kill "$DPID" 2>/dev/null && wait "$DPID" 2>/dev/null
  [[ -n ${VPID:-} ]] && kill "$VPID" 2>/dev/null && wait "$VPID" 2>/dev/null
  rm -rf "$W"
}

fail() {
  echo "FAIL: $*"
  echo "--- virtual bench"
  tail -20 "$W/vb.out" 2>/dev/null || true
  echo "--- daemon"
  tail -40 "$W/d.out" 2>/dev/null || true
  exit 1
}

E2E_TABLE_DEVICE=${E2E_TABLE_DEVICE:-}
E2E_CHAMBER_DEVICE=${E2E_CHAMBER_DEVICE:-}
E2E_IMU_LAYOUT=${E2E_IMU_LAYOUT:-}

# A loaded machine (user-mode-linux on 2 shared cores) can hold the IMU up for more than the
# default 0.5 s: a longer imu_timeout keeps a test about its own fault.
E2E_SLOW_IMU=$'[safety]\nimu_timeout = "2 s"'

e2e_bench_file() {
  : "${E2E_TABLE_DEVICE:=$DEV/tables/imubench-ref-2axis-tcp.toml}"
  : "${E2E_CHAMBER_DEVICE:=$DEV/chambers/watlow-f4-style.toml}"
  : "${E2E_IMU_LAYOUT:=$DEV/imus/navgrade_fd.toml}"
  cat >"$W/bench.toml" <<TOML
[bench]
name = "e2e"
storage = "$W/imubench.db"
control_socket = "$W/control.sock"
${E2E_BENCH_EXTRA:-}
[site]
latitude = "55.7558 deg"
height = "150 m"
[table]
device = "$E2E_TABLE_DEVICE"
port = 1502
max_rate = "30 deg/s"
max_accel = "10 deg/s^2"
reading_gap = "${E2E_TABLE_READING_GAP:-3 s}"
${E2E_TABLE_EXTRA:-}
[chamber]
device = "$E2E_CHAMBER_DEVICE"
port = 1503
safe_setpoint = "23 degC"
over_temperature = "90 degC"
${E2E_CHAMBER_EXTRA:-}
[imu]
layout = "$E2E_IMU_LAYOUT"
interface = "vcan0"
serial = "E2E-1"
${1:-}
TOML
}

# The bench file's [imu] max_clock_ratio for a virtual bench at --time-scale SCALE: its IMU's
# clock runs SCALE times the receive clock; a quarter more for the sender's batching.
e2e_clock_ratio() {
  awk -v s="$1" 'BEGIN { r = int(s * 1.25 + 0.999); print (r < 2 ? 2 : r) }'
}

e2e_start_vb() {
  : "${E2E_TABLE_DEVICE:=$DEV/tables/imubench-ref-2axis-tcp.toml}"
  : "${E2E_CHAMBER_DEVICE:=$DEV/chambers/watlow-f4-style.toml}"
  : "${E2E_IMU_LAYOUT:=$DEV/imus/navgrade_fd.toml}"
  : >"$W/vb.out"
  local wd=()
  grep -q '^\[host_watchdog\]' "$E2E_TABLE_DEVICE" &&
    wd=(--host-watchdog-timeout "${E2E_WATCHDOG_TIMEOUT:-2}")
  "$VB" --table "$E2E_TABLE_DEVICE" --chamber "$E2E_CHAMBER_DEVICE" --imu "$E2E_IMU_LAYOUT" \
    --can vcan0 "${wd[@]}" "$@" >>"$W/vb.out" 2>&1 &
  VPID=$!
  local _
  for _ in $(seq 300); do grep -q '^ready' "$W/vb.out" && return 0; sleep 0.1; done
  fail "virtual bench not ready"
}

e2e_stop_vb() {
  [[ -n ${VPID:-} ]] || return 0
  kill "$VPID" 2>/dev/null
  wait "$VPID" 2>/dev/null
  VPID=
}

e2e_start_daemon() {
  "$DAEMON" --bench "$W/bench.toml" --stderr "$@" >"$W/d.out" 2>&1 &
  DPID=$!
  local _
  for _ in $(seq 300); do [[ -S $W/control.sock ]] && return 0; sleep 0.1; done
  fail "daemon control socket did not appear"
}

e2e_start() {
  [[ -e $W/bench.toml ]] || e2e_bench_file
  e2e_start_vb --time-scale "$@"
  e2e_start_daemon
}

e2e_stop_daemon() {
  kill "$DPID"
  wait "$DPID" || fail "daemon exit status after SIGTERM"
  DPID=
  [[ -e $W/control.sock ]] && fail "control socket left behind"
  return 0
}

e2e_py() {
  PYTHONPATH="$SRC/tests/daemon/e2e${PYTHONPATH:+:$PYTHONPATH}" python3 - "$W" "$@"
}

# The navigation-grade bench of the calibrating e2e tests: the IMU layout at 5 ms (E2E_IMU_LAYOUT),
# its truth (TRUTH), and the bundled plans with the calibration they feed in $W/direct.toml
# (direct) and $W/12run.toml (pipeline, its direct part direct_two_axis).
e2e_navgrade_bench() {
  sed 's/^sample_period = "1 ms"/sample_period = "5 ms"/' "$DEV/imus/navgrade_fd.toml" >"$W/imu.toml"
  grep -q '^sample_period = "5 ms"' "$W/imu.toml" || fail "IMU layout copy"
  E2E_IMU_LAYOUT=$W/imu.toml
  TRUTH=$SRC/tests/tools/data/truth_nav_grade.json
  sed 's/^name = "direct_two_axis"/&\ncalibration = "direct"/' \
    "$SRC/plans/library/direct_two_axis.toml" >"$W/direct.toml"
  sed 's/^name = "two_axis_12run"/&\ncalibration = "pipeline"\ndirect_plan = "direct_two_axis"/' \
    "$SRC/plans/library/two_axis_12run.toml" >"$W/12run.toml"
}

# The plan's table limits stay below the bench file's (30 deg/s, 10 deg/s^2).
e2e_plan_head() {
  cat <<TOML
[plan]
name = "$1"
${2:+description = \"$2\"}
[table]
kind = "two-axis"
outer_axis_heading = "90 deg"
max_rate = "20 deg/s"
max_accel = "10 deg/s^2"
TOML
}

e2e_plan_chamber() {
  cat <<TOML
[chamber]
min_temp = "$1 degC"
max_temp = "$2 degC"
max_ramp = "5 degC/min"
${3:+initial = \"$3 degC\"}
TOML
}

e2e_hold() {
  printf '[[step]]\ntype = "hold"\nduration = "%s"\nlabel = "%s"\n' "$2" "$1"
}

e2e_rotate() {
  printf '[[step]]\ntype = "rotate"\naxis = "%s"\nangle = "%s"\ndirection = "%s"\n' "$2" "$3" "$4"
  printf 'rate = "10 deg/s"\naccel = "5 deg/s^2"\nlabel = "%s"\n' "$1"
}

e2e_truth_targets() {
  python3 - "$1" <<'PY' || fail "stored coefficients against the truth"
import re, sys
rows = [l for l in sys.argv[1].splitlines() if " error " in l and " limit " in l]
assert rows, "no comparison rows"
bad_angle = [l for l in rows if "OUTSIDE" in l and ".bias." not in l]
assert not bad_angle, "scale/misalignment/table outside 3 arcsec / 10 ppm:\n" + "\n".join(bad_angle)
bias_out = [l for l in rows if "OUTSIDE" in l and ".bias." in l]
assert len(bias_out) <= 1, "more than one bias outside 2 sigma:\n" + "\n".join(bias_out)
for l in bias_out:
    m = re.search(r"error\s+([-+0-9.]+)\s+\S+\s+limit\s+([0-9.]+)", l)
    assert abs(float(m.group(1))) <= 1.5 * float(m.group(2)), "bias beyond 3 sigma: " + l
print("ok: %d parameters compared, %d bias(es) outside 2 sigma" % (len(rows), len(bias_out)))
PY
}
