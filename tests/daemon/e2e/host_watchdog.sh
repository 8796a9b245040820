#!/usr/bin/env bash
# Issue 28, host-loss safety, through the real processes on vcan at time scale 1 (virtual time
# = wall time): `kill -9` of imubenchd in the middle of a 10 deg/s rotation. The table's
# controller (the virtual bench, its device file's [host_watchdog]: heartbeat register, 0.5 s)
# sees the heartbeat the daemon wrote at every poll stop, brakes the axis to rest and opens
# its interlock. Read from the controller's registers by a third-party Modbus client that
# never writes the heartbeat (modbus_peek.py):
#   - the axis is at rest (moving bit clear, angle no longer changing) within 1 s of the kill
#     (the last heartbeat came at most one 20 ms poll before it) and it turned less than
#     10 deg after the kill;
#   - the interlock is open (not tripped, no emergency stop latched);
# then the daemon starts again on the same database, `imubench rearm` closes the interlock,
# `imubench resume 1` re-runs the interrupted rotation and the plan completes.
# Usage: host_watchdog.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

{
  e2e_plan_head watchdog "host watchdog e2e: a hold, a half turn, a hold"
  e2e_hold h1 "2 s"
  e2e_rotate r1 outer "180 deg" +
  e2e_hold h2 "2 s"
} >"$W/plan.toml"

e2e_bench_file "$E2E_SLOW_IMU"
E2E_WATCHDOG_TIMEOUT=0.5  # the shipped device file's (lib.sh gives other tests 2 s)
e2e_start 1

e2e_py "$DPID" "$E2E_TABLE_DEVICE" "$W/plan.toml" <<'PY' || fail "kill -9 mid-rotation"
import json, os, signal, sys, time
from e2e_client import check, start_run
from modbus_peek import TablePeek
work, dpid, device, plan = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
peek = TablePeek(device, 1502)
c = start_run(work, plan)
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "r1 start", 60)
a0 = peek.read()["angles_deg"][0]

def turned(a):
    return (a - a0 + 180.0) % 360.0 - 180.0

# Into the 10 deg/s cruise (the 5 deg/s^2 ramp covers 10 deg): past 30 deg of the half turn.
end = time.monotonic() + 30
while time.monotonic() < end:
    s = peek.read()
    if s["moving"][0] and turned(s["angles_deg"][0]) > 30.0:
        break
    time.sleep(0.02)
check(s["moving"][0] and s["interlock_closed"] and 30.0 < turned(s["angles_deg"][0]) < 170.0,
      "the outer axis turns mid-rotation, interlock closed: %s" % s)
os.kill(dpid, signal.SIGKILL)
kill_t = time.monotonic()
at_kill = s["angles_deg"][0]
# The controller's registers for 3 s after the kill (a read takes a few ms).
samples = []
while time.monotonic() < kill_t + 3.0:
    r = peek.read()
    samples.append((time.monotonic() - kill_t, r))
last = samples[-1][1]
final = last["angles_deg"][0]
still = [i for i, (t, r) in enumerate(samples) if not r["moving"][0]]
check(bool(still), "the axis comes to rest: %s" % last)
first_still = still[0]
# The first sample after the first still one that moves or lies elsewhere, with its neighbours:
# what a failure prints (it failed once on a loaded CI-like machine, 0.582 s after the kill).
later = [k for k in range(first_still, len(samples))
         if samples[k][1]["moving"][0] or abs(samples[k][1]["angles_deg"][0] - final) >= 1e-4]
check(not later,
      "at rest from %.3f s after the kill on, at %.4f deg%s" % (
          samples[first_still][0], final,
          "" if not later else "; not so at %s" % [
              (round(t, 3), r["moving"][0], r["angles_deg"][0])
              for t, r in samples[max(first_still, later[0] - 2):later[0] + 3]]))
# The sample before the first still one was still moving: the axis stopped in between.
t_rest = samples[first_still][0]
check(t_rest <= 0.95, "at rest within 1 s of the last heartbeat: %.3f s after the kill "
      "(0.5 s timeout + braking)" % t_rest)
travel = (final - at_kill + 180.0) % 360.0 - 180.0
check(0.0 <= travel < 10.0, "%.2f deg turned after the kill (10 deg/s: < 10 deg)" % travel)
check(not last["interlock_closed"], "the controller opened its interlock: %s" % last)
check(not last["interlock_tripped"] and not last["estop"],
      "no trip or emergency stop latched (the host's re-arm closes it): %s" % last)
json.dump({"rest_s": t_rest, "travel_deg": travel}, open(work + "/watchdog.json", "w"))
PY
wait "$DPID" 2>/dev/null || true
DPID=
grep -q "host watchdog" "$W/vb.out" || fail "the virtual bench did not report its host watchdog"
mv "$W/d.out" "$W/d1.out"

e2e_start_daemon
e2e_py "$CLI" "$E2E_TABLE_DEVICE" <<'PY' || fail "rearm and resume after the restart"
import subprocess, sys, time
from e2e_client import Client, check
from modbus_peek import TablePeek
work, cli, device = sys.argv[1], sys.argv[2], sys.argv[3]
c = Client(work + "/control.sock")
c.subscribe("run")
end = time.monotonic() + 30  # the first poll of the restarted daemon
while True:
    st = c.reply({"cmd": "status"})["result"]
    if "age_s" in st["table"] or time.monotonic() > end:
        break
    time.sleep(0.05)
check(st["table"]["interlock"] == "open", "the restarted daemon shows the interlock open: %s"
      % st["table"])


def rearm_and_resume():
    p = subprocess.run([cli, "rearm"], capture_output=True, text=True, timeout=30)
    check(p.returncode == 0, "imubench rearm: %s%s" % (p.stdout, p.stderr))
    check(TablePeek(device, 1502).read()["interlock_closed"], "the controller's interlock closed")
    p = subprocess.run([cli, "resume", "1"], capture_output=True, text=True, timeout=30)
    check(p.returncode == 0 and "run 1 resumed" in p.stdout,
          "imubench resume 1: %s%s" % (p.stdout, p.stderr))


rearm_and_resume()
# A stall of user-mode Linux longer than the 0.5 s watchdog (two of them beside each other on
# 2 cores did it) opens the interlock again in the resumed run, and the daemon pauses the run
# with an alarm, as it must: re-arm and resume as an operator would, at most twice more.
for attempt in range(3):
    fin = c.wait_event(lambda e: (e["event"] == "run_finished" and e["run"] == 1) or
                       (e["event"] == "state" and e.get("state") == "paused"),
                       "run end (or a pause)", 120)
    if fin["event"] == "run_finished" or attempt == 2:
        break
    print("note: the resumed run paused (the controller's watchdog ran out under load): "
          "re-arm and resume again", flush=True)
    rearm_and_resume()
check(fin["event"] == "run_finished", "the run ends (not paused a third time): %s" % fin)
check(fin["state"] == "finished" and fin["exit"] == "completed", "run 1 completed: %s" % fin)
starts = [e["label"] for e in c.events if e["event"] == "step_started"]
# No rotation may touch the gap the kill left (docs/faults.md): the interrupted rotation runs
# again with the hold before it.
check(starts[:2] == ["h1", "r1"], "the interrupted rotation re-ran with its hold before it: %s"
      % starts)
PY
e2e_stop_daemon
echo "PASS"
