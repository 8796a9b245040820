#!/usr/bin/env bash
# Issue 15, faults through the real process: the IMU goes silent mid-rotation (virtual bench:
# SIGRTMIN+3 toggles the silence; its clock runs on). imubenchd stays up, stops motion, pauses
# the plan with an alarm on the socket and in the log; `resume` is refused while the IMU is
# silent and continues the plan once its frames arrive again; the recording is intact up to the
# silence and goes on after it (one time axis, the only gap is the silence); the hold before
# the interrupted rotation runs again with it (no rotation next to the gap).
# Usage: fault_imu_silent.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start 5

e2e_py "$VPID" "$CLI" "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "IMU silent"
import os, signal, sys, time
from e2e_client import check
from fault_checks import *
work, vpid, cli, plan = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
c = start_smoke_run(work, plan, into="r1", after_s=0.5)
silent_from = status(c)["imu_time_s"]
os.kill(vpid, signal.SIGRTMIN + 3)
wait_alarm(c, "IMU silent")
alarm_logged(work, "IMU silent")
motion_stopped(c)
resume_refused(c, "IMU is silent")
check(status(c)["imu_time_s"] - silent_from < 1.0, "no IMU sample while it is silent")
os.kill(vpid, signal.SIGRTMIN + 3)
end = time.monotonic() + 20
while status(c)["imu_time_s"] < silent_from + 2.0 and time.monotonic() < end:
    time.sleep(0.1)
back_at = status(c)["imu_time_s"]
check(back_at > silent_from + 2.0, "the IMU streams again")
resume_when_back(c)
# The silence is a gap next to r1 (issue 28 item 5): h1 runs again before r1, both h1 kept.
recording_intact(work, cli, c.run, ["h1", "h1", "r1", "h2"], allowed_gap=(silent_from, back_at))
PY
e2e_stop_daemon
echo "PASS"
