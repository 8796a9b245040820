#!/usr/bin/env bash
# Issue 15, faults through the real process: the chamber runs away above the bench's
# over_temperature (30 degC here) during a run (virtual bench: SIGRTMIN+4 sends it towards
# 200 degC, as a setpoint changed at its front panel or a controller fault would). imubenchd
# stays up, sends the chamber to its safe setpoint (23 degC), stops motion, pauses the plan
# with an alarm on the socket and in the log, keeps recording IMU, table and chamber; `resume`
# is refused while the chamber is over temperature and continues once it has cooled below it.
# Usage: fault_chamber_over_temperature.sh <imubench-virtual-bench> <imubenchd> <imubench> <src>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
e2e_bench_file "$E2E_SLOW_IMU"
sed -i 's/^over_temperature = "90 degC"/over_temperature = "30 degC"/' "$W/bench.toml"
grep -q '^over_temperature = "30 degC"' "$W/bench.toml" || fail "bench file: over_temperature"
e2e_start 5 --fault-chamber-runaway 200

e2e_py "$VPID" "$CLI" "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "chamber over temperature"
import os, signal, sys
from e2e_client import check, read_csv
from fault_checks import *
work, vpid, cli, plan = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
c = start_smoke_run(work, plan, into="h1", after_s=0.2)
os.kill(vpid, signal.SIGRTMIN + 4)
wait_alarm(c, "chamber over temperature")
alarm_at = status(c)["imu_time_s"]
alarm_logged(work, "chamber over temperature")
resume_refused(c, "over temperature")
motion_stopped(c)
resume_when_back(c, limit=60)
recording_intact(work, cli, c.run, ["h1", "r1", "h2"])
chamber = read_csv("%s/export-%d/chamber.csv" % (work, c.run))
after = [r for r in chamber if float(r["t"]) > alarm_at + 1.0]
check(len(after) > 3 and all(float(r["setpoint"]) == 23.0 for r in after),
      "chamber at its safe setpoint after the alarm, still recorded (%d samples)" % len(after))
check(max(float(r["temp"]) for r in chamber) > 30.0, "the over temperature is in the recording")
PY
e2e_stop_daemon
echo "PASS"
