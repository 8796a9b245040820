#!/usr/bin/env bash
# Issue 17, defect 4, through the real imubenchd on vcan: the virtual IMU's counter and time
# stamp start so that both wrap 80 s (simulated) in, a plan runs across the wrap, and the IMU
# restarts mid-run (SIGRTMIN+1: 0.2 s silent, then counter and time stamp from 0). Checks:
# the wrap stays a wrap and the restart is a restart: an "imu_restart" event on topic "run",
# status imu_restarts 1 and no lost samples, the restart in the daemon's log at warning; the
# run completes; its stored IMU time axis is continuous (strictly increasing, every step one
# period except one at the restart no longer than its silence plus scheduling slack, no
# 4000 s jump) and runs through the wrap. The hold the restart fell into runs again (issue 28
# item 5: no stored segment spans the restart's gap; event recording_gap).
# Usage: imu_restart.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
{
  e2e_plan_head imu-restart
  e2e_hold h1 "60 s"
  e2e_hold h2 "60 s"
} >"$W/plan.toml"
e2e_start 5 --imu-wrap-at 80

e2e_py "$VPID" <<'PY' || fail "client checks"
import os, signal, sys, time
from e2e_client import Client, check, read_csv, plan_file

work, vb_pid = sys.argv[1], int(sys.argv[2])
WRAP = 4294.967296  # the 2^32 us time stamp's wrap: stored IMU times continue past it
c = Client(work + "/control.sock")
c.subscribe("run")

def imu_time(limit=30.0):
    end = time.time() + limit
    while time.time() < end:
        st = c.reply({"cmd": "status"})["result"]
        if "imu_time_s" in st:
            return st["imu_time_s"]
        time.sleep(0.05)
    raise SystemExit("no IMU time in status")

t_start = imu_time()
check(t_start < WRAP - 2.0, "the run starts before the wrap (IMU time %.3f s)" % t_start)
start = c.reply({"cmd": "start", "plan": plan_file(work + "/plan.toml")})
check(start["ok"], "start: %s" % start)
run = start["result"]["run"]
end = time.time() + 60
while imu_time() < WRAP + 5.0:
    if time.time() > end:
        raise SystemExit("the IMU time did not pass the wrap")
    time.sleep(0.1)
st = c.reply({"cmd": "status"})["result"]
check(st["imu_restarts"] == 0 and st["imu_lost_samples"] == 0,
      "the wrap is no restart and loses nothing: %s" % st)
os.kill(vb_pid, signal.SIGRTMIN + 1)
ev = c.wait_event(lambda e: e["event"] == "imu_restart", "imu_restart event", limit=30)
check(ev.get("run") == run and ev["restarts"] == 1 and "IMU restarted: counter" in ev["message"],
      "imu_restart event on topic run: %s" % ev["message"])
gap = c.wait_event(lambda e: e["event"] == "recording_gap", "recording_gap event", limit=30)
check(gap["run"] == run and gap["label"] in ("h1", "h2"), "the gap is an event: %s" % gap)
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end", 120)
check(fin["state"] == "finished" and fin["exit"] == "completed", "the run completed")
st = c.reply({"cmd": "status"})["result"]
check(st["imu_restarts"] == 1, "status imu_restarts 1")
check(st["imu_lost_samples"] == 0, "no lost samples: %d" % st["imu_lost_samples"])

exp = c.reply({"cmd": "export", "run": run, "dir": "export"})
check(exp["ok"], "export: %s" % exp)
ts = [float(r["t"]) for r in read_csv(work + "/exports/export/imu.csv")]
steps = [b - a for a, b in zip(ts, ts[1:])]
check(min(steps) > 0, "stored IMU time strictly increasing")
odd = [(ts[k], d) for k, d in enumerate(steps) if abs(d - 0.001) > 2e-6]
check(len(odd) == 1, "every step one period but the restart's: %s" % odd[:5])
check(odd[0][1] < 0.5, "the restart's step %.3f s: its silence (0.2 s simulated), no jump"
      % odd[0][1])
check(ts[0] < WRAP < odd[0][0], "the stored axis runs through the wrap (%.3f .. %.3f s)"
      % (ts[0], ts[-1]))
check(ts[-1] - ts[0] < 200, "no time jump: %.3f s stored for a 120 s plan and a re-run 60 s hold"
      % (ts[-1] - ts[0]))
segs = read_csv(work + "/exports/export/segments.csv")
check([s["label"] for s in segs] == ["h1", "h2"],
      "the hold with the gap is stored only as its re-run: %s" % [s["label"] for s in segs])
gap_a, gap_b = odd[0][0], odd[0][0] + odd[0][1]
for s in segs:
    check(not (float(s["t0"]) < gap_b and float(s["t1"]) > gap_a), "%s spans no gap" % s["label"])
    d = float(s["t1"]) - float(s["t0"])
    check(59.5 < d < 61.5, "hold %s measured on the IMU clock: %.3f s of 60 s" % (s["label"], d))
PY
grep -q "warning: IMU restarted: counter" "$W/d.out" || fail "the restart is not in the daemon's log"
echo "ok: the restart is in the daemon's log at warning"
e2e_stop_daemon
echo PASS
