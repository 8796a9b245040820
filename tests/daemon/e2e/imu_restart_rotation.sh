#!/usr/bin/env bash
# Issue 28 item 5, through the real imubenchd on vcan: the virtual IMU restarts (SIGRTMIN+1:
# 0.2 s silent, then counter and time stamp from 0) in the middle of a 180 deg turn about the
# outer axis (x_B). The daemon must not keep that turn as a complete rotation (it would
# integrate to about 178 deg). Checks: an imu_restart event, a recording_gap event and an
# alarm naming the steps that run again; the hold before the turn and the turn run again (the
# table goes back to the turn's start first), the run completes; no stored segment spans the
# gap and no rotation is next to it; the turn is stored once, after the restart, and its
# x gyro integrates to 180 deg within the gyro noise and the Earth rate (0.05 deg).
# Usage: imu_restart_rotation.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
{
  e2e_plan_head imu-restart-rotation
  e2e_hold h1 "10 s"
  e2e_rotate r1 outer "180 deg" +
  e2e_hold h2 "10 s"
} >"$W/plan.toml"
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start 5

e2e_py "$VPID" <<'PY' || fail "client checks"
import math, os, signal, sys, time
from e2e_client import Client, check, read_csv, start_run

work, vb_pid = sys.argv[1], int(sys.argv[2])
c = start_run(work, work + "/plan.toml")
run = c.run
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "r1 start", 60)
t0 = c.reply({"cmd": "status"})["result"]["imu_time_s"]
while c.reply({"cmd": "status"})["result"]["imu_time_s"] < t0 + 8.0:  # 8 s into the 20 s turn
    time.sleep(0.01)
os.kill(vb_pid, signal.SIGRTMIN + 1)
ev = c.wait_event(lambda e: e["event"] == "imu_restart", "imu_restart event", limit=30)
check(ev.get("run") == run, "imu_restart during r1: %s" % ev["message"])
gap = c.wait_event(lambda e: e["event"] == "recording_gap", "recording_gap event", limit=30)
check(gap["run"] == run and gap["label"] == "h1" and gap["to_t"] - gap["from_t"] < 1.0,
      "the gap is an event; the run goes on at h1: %s" % gap["message"])
alarm = c.wait_event(lambda e: e["event"] == "alarm" and "run again" in e["message"],
                     "alarm", limit=30)
check(alarm["label"] == "r1", "an alarm at r1: %s" % alarm["message"])
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end", 120)
check(fin["state"] == "finished" and fin["exit"] == "completed", "the run completed: %s" % fin)
# (the first r1's start was taken by the wait above)
starts = [e["label"] for e in c.events if e["event"] == "step_started"]
check(starts == ["h1", "h1", "r1", "h2"], "h1, then after the restart h1, r1 (whole) and h2: %s"
      % starts)

exp = c.reply({"cmd": "export", "run": run, "dir": "export"})
check(exp["ok"], "export: %s" % exp)
imu = read_csv(work + "/exports/export/imu.csv")
t = [float(r["t"]) for r in imu]
holes = [(a, b) for a, b in zip(t, t[1:]) if b - a > 0.005]
check(len(holes) == 1, "one gap in the IMU data, the restart's: %s" % holes)
a, b = holes[0]
segs = read_csv(work + "/exports/export/segments.csv")
labels = [s["label"] for s in segs]
check(labels == ["h1", "h1", "r1", "h2"], "h1 on each side of the gap, r1 once: %s" % labels)
check(float(segs[0]["t1"]) <= a and float(segs[1]["t0"]) >= b,
      "the gap (%.3f-%.3f s) lies between the two h1 holds" % (a, b))
r1 = segs[2]
r0, r1t = float(r1["t0"]), float(r1["t1"])
check(r0 > b, "r1's segment is the re-run after the restart")
x = sum(float(r["dthx"]) for r in imu if r0 < float(r["t"]) <= r1t)
deg = math.degrees(x)
check(abs(deg - 180.0) < 0.05, "the stored r1 integrates to %.4f deg about x_B" % deg)
PY
e2e_stop_daemon
echo PASS
