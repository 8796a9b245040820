#!/usr/bin/env bash
# Issue 16, thermal resume, through the real imubenchd on vcan: a two-point thermal plan (fixed
# soaks, a tiny body), `kill -9` of imubenchd inside the second point after its soak and first
# hold. Checks, after the restart and `imubench resume RUN`:
#   - the run resumes at the interrupted point's chamber step (T26C/soak), not at the
#     interrupted step; the first point's steps are not run again;
#   - every step stored once, in plan order (the second point's segments stored before the kill
#     are discarded: event segments_discarded); the samples stored before the kill are kept;
#   - the completed run stores one point_coefficients result per temperature point, listed by
#     `imubench results --serial`.
# Waits on events and the store, never on fixed sleeps (the kill lands on a step_started event).
# Usage: thermal_resume.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

{
  e2e_plan_head thermal_resume "thermal resume e2e: two soak points, a tiny body"
  e2e_plan_chamber 0 40
  cat <<'TOML'
[[step]]
type = "thermal"
setpoints = ["22 degC", "26 degC"]
mode = "soak"
soak = "5 s"
  [[step.steps]]
  type = "hold"
  duration = "3 s"
  label = "h1"
  [[step.steps]]
  type = "rotate"
  axis = "outer"
  angle = "90 deg"
  direction = "+"
  rate = "10 deg/s"
  accel = "5 deg/s^2"
  label = "r1"
  [[step.steps]]
  type = "hold"
  duration = "3 s"
  label = "h2"
TOML
} >"$W/thermal_plan.toml"

SCALE=5
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start $SCALE

# Into T26C/r1 (T26C/soak and T26C/h1 finished), then kill -9 of imubenchd.
e2e_py "$DPID" "$W/thermal_plan.toml" <<'PY' || fail "run and kill -9"
import json, os, signal, sys
from e2e_client import check, start_run
work, dpid, plan = sys.argv[1], int(sys.argv[2]), sys.argv[3]
c = start_run(work, plan)
check(c.run == 1, "the first run is run 1")
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "T26C/r1", "T26C/r1", 300)
os.kill(dpid, signal.SIGKILL)
PY
wait "$DPID" 2>/dev/null || true
DPID=
mv "$W/d.out" "$W/d1.out"

e2e_py <<'PY' || fail "the database after kill -9"
import json, sqlite3, sys
from e2e_client import check
work = sys.argv[1]
db = sqlite3.connect(work + "/imubench.db")
check(db.execute("PRAGMA integrity_check").fetchone()[0] == "ok", "integrity_check ok")
stored = [l for (l,) in db.execute("SELECT label FROM segments WHERE run_id = 1 ORDER BY idx")]
check(stored[:5] == ["T22C/soak", "T22C/h1", "T22C/r1", "T22C/h2", "T26C/soak"],
      "the first point and the second's soak stored before the kill: %s" % stored)
first = db.execute("SELECT t0, t1 FROM segments WHERE run_id = 1 AND idx < 4 ORDER BY idx").fetchall()
last_t, n = db.execute("SELECT max(t), count(*) FROM imu_samples WHERE run_id = 1").fetchone()
json.dump({"first": first, "last_t": last_t, "n": n}, open(work + "/kill.json", "w"))
PY

e2e_start_daemon
e2e_py "$CLI" <<'PY' || fail "resume the interrupted thermal run"
import json, subprocess, sys
from e2e_client import Client, check
work, cli = sys.argv[1], sys.argv[2]
c = Client(work + "/control.sock")
c.subscribe("run")
p = subprocess.run([cli, "resume", "1"], capture_output=True, text=True, timeout=30)
check(p.returncode == 0 and "run 1 resumed at step 5" in p.stdout,
      "imubench resume 1 goes back to the point's soak (step 5): %s%s" % (p.stdout, p.stderr))
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == 1, "run end", 300)
check(fin["state"] == "finished" and fin["exit"] == "completed", "run 1 completed: %s" % fin)
starts = [e["label"] for e in c.events if e["event"] == "step_started"]
check(starts == ["T26C/soak", "T26C/h1", "T26C/r1", "T26C/h2"],
      "after the resume the second point runs whole from its soak, the first not: %s" % starts)
c.wait_event(lambda e: e["event"] == "point_results" and e["run"] == 1, "point results", 120)
PY

e2e_py "$CLI" <<'PY' || fail "the resumed thermal run's data"
import json, sqlite3, subprocess, sys
from e2e_client import check
work, cli = sys.argv[1], sys.argv[2]
k = json.load(open(work + "/kill.json"))
db = sqlite3.connect(work + "/imubench.db")
segs = db.execute("SELECT label, t0, t1 FROM segments WHERE run_id = 1 ORDER BY idx").fetchall()
labels = [s[0] for s in segs]
check(labels == ["T22C/soak", "T22C/h1", "T22C/r1", "T22C/h2",
                 "T26C/soak", "T26C/h1", "T26C/r1", "T26C/h2"],
      "every step stored once, in order: %s" % labels)
check([list(s[1:]) for s in segs[:4]] == [list(f) for f in k["first"]],
      "the first point's segments are the ones stored before the kill")
check(segs[4][1] > k["last_t"], "the second point's soak re-ran after the kill")
kept = db.execute("SELECT count(*) FROM imu_samples WHERE run_id = 1 AND t <= ?",
                  (k["last_t"],)).fetchone()[0]
check(kept == k["n"], "the %d samples stored before the kill are kept" % k["n"])
ev = db.execute("SELECT count(*) FROM events WHERE run_id = 1 AND kind = 'segments_discarded'")
check(ev.fetchone()[0] == 1, "one segments_discarded event")
pts = db.execute("SELECT imu_serial, temperature_c, json FROM results WHERE run_id = 1 AND "
                 "kind = 'point_coefficients' ORDER BY id").fetchall()
check([json.loads(j)["point"] for (_, _, j) in pts] == ["T22C/soak", "T26C/soak"] and
      all(s == "E2E-1" for (s, _, _) in pts), "one result per point: %s" % pts)
p = subprocess.run([cli, "results", "--serial", "E2E-1", "--db", work + "/imubench.db"],
                   capture_output=True, text=True, timeout=30)
check(p.returncode == 0 and "point T22C/soak" in p.stdout and "point T26C/soak" in p.stdout,
      "results --serial lists the points: %s%s" % (p.stdout, p.stderr))
PY
e2e_stop_daemon
echo "PASS"
