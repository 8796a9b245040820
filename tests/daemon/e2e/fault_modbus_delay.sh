#!/usr/bin/env bash
# Issue 15, faults through the real process: every Modbus reply (table and chamber) comes
# 700 ms late, past the device files' 300/500 ms reply timeouts, mid-rotation (virtual bench:
# SIGRTMIN+2 toggles the delay). imubenchd stays up and keeps answering `status` (polling
# reads make one attempt, a silent device is tried once a second: no call blocks the loop
# longer than one reply timeout), keeps recording the IMU, stops motion and pauses with an alarm on the
# socket and in the log; `resume` is refused while the table does not answer and continues the
# plan once the replies are on time again (after `rearm`: the late heartbeats let the
# controller's host watchdog open the interlock meanwhile, issue 28).
# Usage: fault_modbus_delay.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start 5 --fault-signal-reply-delay-ms 700

e2e_py "$VPID" "$CLI" "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "Modbus delay"
import os, signal, sys, time
from e2e_client import check
from fault_checks import *
work, vpid, cli, plan = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
c = start_smoke_run(work, plan, into="r1", after_s=0.3)
os.kill(vpid, signal.SIGRTMIN + 2)
wait_alarm(c, "table not answering")
alarm_logged(work, "table not answering")
# While the replies stay late: status answers every time, the IMU recording goes on.
t0 = status(c)["imu_time_s"]
slowest = 0.0
end = time.monotonic() + 4.0
while time.monotonic() < end:
    st, took = timed_status(c)
    slowest = max(slowest, took)
    time.sleep(0.05)
print("slowest status reply during the fault: %.3f s" % slowest)
# Polling reads make one attempt (300 ms table, 500 ms chamber timeout), a silent device is
# tried once a second: a table and a chamber attempt back to back are the longest block.
check(slowest < 1.5, "status answers during the fault within one reply timeout of each device "
      "(slowest %.3f s; the retry chains would be 0.9 s + 1.5 s)" % slowest)
check(st["state"] == "paused" and st["imu_time_s"] > t0 + 10.0,
      "paused, IMU still recorded (%.1f s of IMU time in 4 s)" % (st["imu_time_s"] - t0))
resume_refused(c, "not answering")
os.kill(vpid, signal.SIGRTMIN + 2)
motion_stopped(c, limit=30)
# The heartbeats came late too: the controller's host watchdog (0.5 s) opened the interlock.
# The operator re-arms once the table answers again (refused while it does not).
end = time.monotonic() + 30
while True:
    r = c.reply({"cmd": "rearm"})
    if r["ok"] or time.monotonic() > end:
        break
    time.sleep(0.2)
check(r["ok"], "re-armed once the table answers on time again: %s" % r)
resume_when_back(c, limit=30)
recording_intact(work, cli, c.run, ["h1", "r1", "h2"])
PY
e2e_stop_daemon
echo "PASS"
