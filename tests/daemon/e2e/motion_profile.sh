#!/usr/bin/env bash
# Runs under tools/vcan-run.sh (vcan0 exists). Issue 17, defect 1: the plan's rates and
# accelerations reach the table. The real imubenchd drives the virtual bench (bench limits
# 30 deg/s, 10 deg/s^2; the table's device file allows 300 deg/s, 100 deg/s^2) through
#   a rotate step (outer +180 deg at 10 deg/s, 5 deg/s^2: 2 s ramps, 20 s) and
#   a rate step (inner -15 deg/s for 10 s, 3 deg/s^2: 5 s ramps, 225 deg, 20 s);
# the stored run is exported and, for each step, checked within 2 % against the plan:
# the plateau rate from the stored gyro and from the stored table angles, the ramp
# acceleration from the stored gyro, and the duration of the motion.
# Then refusals before any motion: a plan asking more than the bench allows, a table whose
# device file cannot set the motion profile (refused before the bench is even prepared: no
# run, the daemon stays idle),
# and a bench file asking more than its device file (the daemon does not start; file:line).
# Usage: motion_profile.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

{
  e2e_plan_head profile "issue 17: a rotate step and a rate step at the plan's rate and acceleration"
  e2e_hold h1 "3 s"
  e2e_rotate rot outer "180 deg" +
  e2e_hold h2 "3 s"
  cat <<'TOML'
[[step]]
type = "rate"
axis = "inner"
rate = "15 deg/s"
direction = "-"
duration = "10 s"
accel = "3 deg/s^2"
label = "rate"
TOML
  e2e_hold h3 "3 s"
} >"$W/profile.toml"
sed -e 's/^max_rate = "20 deg\/s"/max_rate = "50 deg\/s"/' "$W/profile.toml" >"$W/too_fast.toml"

e2e_start 4

e2e_py "$W/profile.toml" "$W/too_fast.toml" <<'PY' || fail "motion profile checks"
import math, sys
from e2e_client import Client, check, read_csv, plan_file

work, plan, too_fast = sys.argv[1], sys.argv[2], sys.argv[3]
c = Client(work + "/control.sock")
c.subscribe("run")

# A plan asking more than the bench allows: refused before anything moves, no run stored.
runs_before = len(c.reply({"cmd": "results"})["result"]["runs"])
r = c.reply({"cmd": "start", "plan": plan_file(too_fast)})
check(not r["ok"] and "more than this bench allows (30 deg/s, 10 deg/s^2)" in r["error"]["message"],
      "a plan above the bench's limits is refused: " + r.get("error", {}).get("message", ""))
check(len(c.reply({"cmd": "results"})["result"]["runs"]) == runs_before, "no run recorded")

r = c.reply({"cmd": "start", "plan": plan_file(plan)})
check(r["ok"], "start: %s" % r)
run = r["result"]["run"]
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end", 150)
check(fin["exit"] == "completed", "run completed: %s" % fin)
check(c.reply({"cmd": "export", "run": run, "dir": "export"})["ok"], "export")
imu = [(float(r["t"]), float(r["dthx"]), float(r["dthy"]), float(r["dthz"]))
       for r in read_csv(work + "/exports/export/imu.csv")]
table = [(float(t["t"]), float(t["outer"]), float(t["inner"]))
         for t in read_csv(work + "/exports/export/table.csv")]
segs = {s["label"]: s for s in read_csv(work + "/exports/export/segments.csv")}

# Gyro rate (deg/s, magnitude) per sample from the stored increments.
gyro = []
for (t0, *_), (t1, dx, dy, dz) in zip(imu, imu[1:]):
    gyro.append((t1, math.degrees(math.sqrt(dx * dx + dy * dy + dz * dz) / (t1 - t0))))
check(max(w for _, w in gyro) < 30.0 * 1.02, "never faster than the bench's 30 deg/s")

def fit(xs, ys):
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx

def unwrap(angles):
    out = [angles[0]]
    for a in angles[1:]:
        out.append(out[-1] + (a - out[-1] + 180.0) % 360.0 - 180.0)
    return out

def near(got, want, what):
    check(abs(got - want) <= 0.02 * abs(want), "%s: %.4f, plan %.4f (2 %%)" % (what, got, want))

def motion(label, col, rate, accel, duration):
    t0, t1 = float(segs[label]["t0"]), float(segs[label]["t1"])
    # The motion as the gyro saw it: above 0.2 deg/s inside the step's stored segment.
    moving = [(t, w) for t, w in gyro if t0 - 0.5 <= t <= t1 + 0.5 and w > 0.2]
    check(len(moving) > 100, "%s: the gyro saw the motion (%d samples)" % (label, len(moving)))
    ts, te = moving[0][0], moving[-1][0]
    near(te - ts + 2 * 0.2 / accel, duration, label + ": motion duration from the gyro, s")
    mid = [w for t, w in moving if ts + 0.3 * (te - ts) <= t <= te - 0.3 * (te - ts)]
    near(sorted(mid)[len(mid) // 2], rate, label + ": plateau rate from the stored gyro, deg/s")
    peak = max(w for _, w in moving)
    ramp = [(t, w) for t, w in moving if t < 0.5 * (ts + te) and 0.1 * peak < w < 0.9 * peak]
    check(len(ramp) > 50, "%s: ramp samples (%d)" % (label, len(ramp)))
    near(fit([t for t, _ in ramp], [w for _, w in ramp]), accel,
         label + ": ramp acceleration from the stored gyro, deg/s^2")
    rows = [(t, a) for t, *angles in table for a in [angles[col]]
            if ts + 0.3 * (te - ts) <= t <= te - 0.3 * (te - ts)]
    check(len(rows) > 10, "%s: table angles stored on the plateau (%d)" % (label, len(rows)))
    slope = fit([t for t, _ in rows], unwrap([a for _, a in rows]))
    near(abs(slope), rate, label + ": plateau rate from the stored table angles, deg/s")

motion("rot", 0, 10.0, 5.0, 180.0 / 10.0 + 10.0 / 5.0)
motion("rate", 1, 15.0, 3.0, 10.0 + 2 * 15.0 / 3.0)
PY
if grep "ALARM" "$W/d.out" | grep -q .; then fail "unexpected alarm in the daemon log"; fi

# A table whose device file gives no way to set the profile: the daemon refuses every plan
# that moves it, before anything moves.
e2e_stop_daemon
grep -v -e '^rate_limit' -e '^accel_limit' "$DEV/tables/imubench-ref-2axis-tcp.toml" \
  >"$W/no-profile-table.toml"
E2E_TABLE_DEVICE=$W/no-profile-table.toml e2e_bench_file
e2e_start_daemon
e2e_py "$W/profile.toml" <<'PY' || fail "refusal on a table without a motion profile"
import sys
from e2e_client import Client, check, plan_file

work, plan = sys.argv[1], sys.argv[2]
c = Client(work + "/control.sock")
runs_before = len(c.reply({"cmd": "results"})["result"]["runs"])
r = c.reply({"cmd": "start", "plan": plan_file(plan)})
check(not r["ok"] and "gives no way to set the rate and acceleration" in r["error"]["message"],
      "refused on a table without a motion profile: " + r.get("error", {}).get("message", ""))
check(len(c.reply({"cmd": "results"})["result"]["runs"]) == runs_before, "no run recorded")
check(c.reply({"cmd": "status"})["result"]["state"] == "idle", "the daemon stays idle")
PY
e2e_stop_daemon

# A bench file asking more than its table's device file: refused at load, with file:line.
sed -e 's/^max_rate = "30 deg\/s"/max_rate = "400 deg\/s"/' "$W/bench.toml" >"$W/loose.toml"
line=$(grep -n '^max_rate = "400 deg/s"' "$W/loose.toml" | cut -d: -f1)
status=0
"$DAEMON" --bench "$W/loose.toml" --stderr >"$W/loose.out" 2>&1 || status=$?
[[ $status -ne 0 ]] || fail "imubenchd started on a bench looser than its device file"
grep -q "loose.toml:$line:.*looser than the device file's 300 deg/s" "$W/loose.out" ||
  { cat "$W/loose.out"; fail "no file:line diagnostic for the loose bench limit"; }
echo "ok: a bench file above its device file's limits is refused at $W/loose.toml:$line"
echo "PASS"
