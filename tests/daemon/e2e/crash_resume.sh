#!/usr/bin/env bash
# Issue 15, crash resume, through the real imubenchd on vcan: `kill -9` of the imubenchd
# process itself in the middle of a rotation. Checks:
#   - the database opens cleanly (PRAGMA integrity_check) and at most 1 s of samples (IMU
#     time) is lost: the last stored sample vs the IMU time when the kill landed;
#   - restarted on the same database, the daemon marks the run `interrupted` with the time of
#     its last stored sample;
#   - `imubench resume RUN` continues it at the hold before the interrupted rotation (no
#     rotation next to the gap the kill left: plan_runner.h gapRestart; the hold's segment from
#     before the kill stays, it closes the rotation before it), the interrupted rotation re-runs
#     whole, from its start, and the plan completes;
#   - no other finished step repeated: every other step once in the stored segments, the hold
#     before the rotation once on each side of the gap (a recording_gap event names it); the
#     samples stored before the kill are kept; the run's data is one time axis (strictly
#     increasing) and every stored step is gap-free.
# Then a SIGTERM during a paused run closes it as `interrupted` (not faulted), resumable too.
# Usage: crash_resume.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

{
  e2e_plan_head resume "crash-resume e2e: holds and two signed half turns"
  e2e_hold h1 "5 s"
  e2e_rotate r1 outer "180 deg" +
  e2e_hold h2 "5 s"
  e2e_rotate r2 inner "180 deg" -
  e2e_hold h3 "5 s"
} >"$W/resume_plan.toml"

SCALE=5
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start $SCALE

# Into r2 (steps h1, r1, h2 finished), then kill -9 of imubenchd; the IMU time of the kill is
# bounded from above by the daemon's last status plus the wall time to the kill x time scale.
e2e_py "$DPID" "$SCALE" "$W/resume_plan.toml" <<'PY' || fail "run and kill -9"
import json, os, signal, sys, time
from e2e_client import Client, check, start_run
work, dpid, scale, plan = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
c = start_run(work, plan)
check(c.run == 1, "the first run is run 1")
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r2", "r2 start", 120)
time.sleep(1.0)  # 5 s of plan time into the 20 s half turn
st = c.reply({"cmd": "status"})["result"]
wall_status = time.monotonic()
os.kill(dpid, signal.SIGKILL)
kill_t = st["imu_time_s"] + (time.monotonic() - wall_status) * scale
check(st["state"] == "running" and st["step"]["label"] == "r2", "killed during r2: %s" % st)
json.dump({"kill_t": kill_t}, open(work + "/kill.json", "w"))
PY
wait "$DPID" 2>/dev/null || true
DPID=
mv "$W/d.out" "$W/d1.out"

e2e_py <<'PY' || fail "the database after kill -9"
import json, sqlite3, sys
from e2e_client import check
work = sys.argv[1]
kill_t = json.load(open(work + "/kill.json"))["kill_t"]
db = sqlite3.connect(work + "/imubench.db")
check(db.execute("PRAGMA integrity_check").fetchone()[0] == "ok", "integrity_check ok")
last_t, n = db.execute("SELECT max(t), count(*) FROM imu_samples WHERE run_id = 1").fetchone()
check(kill_t - last_t <= 1.0, "at most 1 s of samples lost: last stored t = %.3f s, kill at "
      "t <= %.3f s (%.3f s)" % (last_t, kill_t, kill_t - last_t))
state = db.execute("SELECT state FROM runs WHERE id = 1").fetchone()[0]
check(state == "running", "still running in the database until the daemon starts again")
# The resume checkpoint vouches only for stored data: every stored step_finished has its
# step's segment stored (the event is written after the segment, never before).
finished = [json.loads(j)["label"] for (j,) in db.execute(
    "SELECT json FROM events WHERE run_id = 1 AND kind = 'step_finished' ORDER BY id")]
stored = [l for (l,) in db.execute("SELECT label FROM segments WHERE run_id = 1 ORDER BY t0")]
check(finished == stored[:len(finished)] and finished == ["h1", "r1", "h2"],
      "each checkpointed step has its segment: finished %s, segments %s" % (finished, stored))
json.dump({"kill_t": kill_t, "last_t": last_t, "n": n}, open(work + "/kill.json", "w"))
db.close()
PY

e2e_start_daemon
PYTHONPATH="$SRC/tools/python" e2e_py "$CLI" <<'PY' || fail "resume the interrupted run"
import json, subprocess, sys
from e2e_client import Client, check
import imubench_client
work, cli = sys.argv[1], sys.argv[2]
k = json.load(open(work + "/kill.json"))
c = Client(work + "/control.sock")
c.subscribe("run")
with imubench_client.Client(work + "/control.sock") as py:
    r = py.results(1)
check(r["state"] == "interrupted", "run 1 marked interrupted at start-up")
check(("last stored sample at t = %.6f s" % k["last_t"]) in r["exit"],
      "with the time of its last stored sample: " + r["exit"])
p = subprocess.run([cli, "resume", "1"], capture_output=True, text=True, timeout=30)
check(p.returncode == 0 and "run 1 resumed at step 3" in p.stdout,
      "imubench resume 1: %s%s" % (p.stdout, p.stderr))
again = subprocess.run([cli, "resume", "1"], capture_output=True, text=True, timeout=30)
check(again.returncode != 0 and "error (bad_state)" in again.stderr,
      "a second resume is refused: " + again.stderr.strip())
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == 1, "run end", 150)
check(fin["state"] == "finished" and fin["exit"] == "completed", "run 1 completed: %s" % fin)
starts = [e["label"] for e in c.events if e["event"] == "step_started"]
check(starts == ["h2", "r2", "h3"],
      "after the resume h2 (the hold before r2), r2 (whole) and h3 run: %s" % starts)
gaps = [e for e in c.events if e["event"] == "recording_gap"]
check(len(gaps) == 1 and gaps[0]["label"] == "h2" and gaps[0]["from_t"] <= k["last_t"],
      "the gap is an event: %s" % gaps)
PY

"$CLI" export 1 --csv "$W/export" --db "$W/imubench.db" >/dev/null || fail "export"
e2e_py <<'PY' || fail "the resumed run's data"
import json, sqlite3, sys
from e2e_client import check, read_csv
work = sys.argv[1]
k = json.load(open(work + "/kill.json"))
segs = read_csv(work + "/export/segments.csv")
labels = [s["label"] for s in segs]
check(labels == ["h1", "r1", "h2", "h2", "r2", "h3"],
      "every step stored once, h2 once on each side of the gap, in order: %s" % labels)
check(float(segs[2]["t1"]) <= k["last_t"] < float(segs[3]["t0"]), "the gap lies between the h2s")
r2 = float(segs[4]["t1"]) - float(segs[4]["t0"])
check(19.0 < r2 < 25.0, "the interrupted half turn re-ran whole: %.2f s of the planned 20 s" % r2)
check(float(segs[4]["t0"]) > k["kill_t"], "r2's stored segment is the re-run, after the kill")
db = sqlite3.connect(work + "/imubench.db")
finished = [json.loads(j)["step"] for (j,) in db.execute(
    "SELECT json FROM events WHERE run_id = 1 AND kind = 'step_finished' ORDER BY id")]
check(finished == [0, 1, 2, 2, 3, 4], "each step finished once, h2 again: %s" % finished)
kept = db.execute("SELECT count(*) FROM imu_samples WHERE run_id = 1 AND t <= ?",
                  (k["last_t"],)).fetchone()[0]
check(kept == k["n"], "the %d samples stored before the kill are kept" % k["n"])
t = [float(r["t"]) for r in read_csv(work + "/export/imu.csv")]
check(all(b > a for a, b in zip(t, t[1:])), "one time axis: sample times strictly increase")
check(t[-1] > k["kill_t"], "samples after the resume appended to the same run")
for s in segs:
    t0, t1 = float(s["t0"]), float(s["t1"])
    inside = [x for x in t if t0 <= x <= t1]
    gap = max(b - a for a, b in zip(inside, inside[1:]))
    check(gap < 0.0025, "step %s gap-free (largest gap %.4f s at 1 kHz)" % (s["label"], gap))
PY

# SIGTERM while paused: the run closes `interrupted` (resumable), not faulted.
e2e_py "$W/resume_plan.toml" <<'PY' || fail "pause then SIGTERM"
import sys
from e2e_client import Client, check, plan_file
work, plan = sys.argv[1], sys.argv[2]
c = Client(work + "/control.sock")
c.subscribe("run")
check(c.reply({"cmd": "start", "plan": plan_file(plan)})["result"]["run"] == 2, "run 2 starts")
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "r1 start", 60)
check(c.reply({"cmd": "pause"})["ok"], "pause run 2")
c.wait_event(lambda e: e["event"] == "state" and e["state"] == "paused", "paused")
PY
e2e_stop_daemon
e2e_start_daemon
e2e_py <<'PY' || fail "run 2 after SIGTERM"
import sys
from e2e_client import Client, check
c = Client(sys.argv[1] + "/control.sock")
r = c.reply({"cmd": "results", "run": 2})["result"]
check(r["state"] == "interrupted" and "daemon stopped" in r["exit"],
      "a SIGTERM during a paused run closes it interrupted: %s" % r)
PY
e2e_stop_daemon
echo "PASS"
