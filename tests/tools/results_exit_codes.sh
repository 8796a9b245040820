#!/bin/sh
# Issue 28 item 8: `imubench results RUN` exits by its verdict, distinctly: 0 PASS, 4 FAIL,
# 5 undetermined (no acceptance limits, a limited parameter not determined, a failed
# calibration, --truth without coefficients or with a parameter held), 1 error; a run without
# results after a crash says it is interrupted and in which step. The runs are imported
# simulations; their verdicts, reports and events are written into the store as the daemon
# writes them (daemon/run_calibration.cpp acceptanceVerdict, daemon/bench_daemon.cpp events).
# Usage: results_exit_codes.sh IMUBENCH PLAN_DIR TRUTH
set -e
bin="$1"; plans="$2"; truth="$3"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
db="$work/runs.db"
fail() { echo "results_exit_codes.sh: $*" >&2; exit 1; }

# expect CODE REGEX command...: exit code and a stdout+stderr match.
expect() {
  want="$1"; regex="$2"; shift 2
  set +e
  out=$("$@" 2>&1); code=$?
  set -e
  printf '%s\n' "$out"
  [ "$code" = "$want" ] || fail "exit code $code, expected $want: $*"
  printf '%s\n' "$out" | grep -Eq -- "$regex" || fail "output does not match /$regex/: $*"
}

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/rec" --rate 20 \
  --seed 7 --noise nav-grade > /dev/null
for i in 1 2 3 4 5 6; do "$bin" import "$work/rec" --db "$db" --plan-name direct_two_axis > /dev/null; done
"$bin" calibrate 6 --db "$db" --method direct --table-errors "$truth" --store-result > /dev/null 2>&1

python3 - "$db" <<'PY'
import json, sqlite3, sys, time
db = sqlite3.connect(sys.argv[1])
def result(run, kind, doc):
    db.execute("INSERT INTO results(run_id, imu_serial, temperature_c, kind, json, created_unix_s)"
               " VALUES (?, 'SIM', 25.0, ?, ?, ?)", (run, kind, json.dumps(doc), time.time()))
def event(run, kind, doc):
    db.execute("INSERT INTO events(run_id, wall_unix_s, severity, kind, json) VALUES (?, ?, 'info', ?, ?)",
               (run, time.time(), kind, json.dumps(doc)))
ok_report = {"method": "direct", "ok": True}
row = {"parameter": "gyro.bias.x", "limit": 0.01, "unit": "deg/h", "limit_text": "0.01 deg/h"}
result(1, "report", ok_report)
result(1, "verdict", {"pass": True, "rows": [dict(row, value=0.001, **{"pass": True})]})
result(2, "report", ok_report)
result(2, "verdict", {"pass": False, "rows": [dict(row, value=0.5, **{"pass": False}),
                                             dict(row, parameter="gyro.bias.y", **{"pass": False},
                                                  why="not determined by this calibration")]})
result(3, "report", {"method": "direct", "ok": False, "error": "gap of 127.05 s"})
result(3, "verdict", {"pass": False, "why": "calibration failed: gap of 127.05 s",
                      "rows": [dict(row, **{"pass": False}, why="not determined by this calibration")]})
result(4, "report", ok_report)
result(4, "verdict", {"pass": None, "rows": [], "why": "no acceptance limits"})
# Run 5: cut off by a crash in its second step.
db.execute("UPDATE runs SET state = 'interrupted', exit_reason = 'the daemon stopped while the run"
           " was active (found at start-up); last stored sample at t = 42.000000 s' WHERE id = 5")
event(5, "step_started", {"run": 5, "step": 0, "label": "hold_z_up"})
event(5, "step_finished", {"run": 5, "step": 0, "label": "hold_z_up"})
event(5, "step_started", {"run": 5, "step": 1, "label": "rate_z_up_pos"})
# Run 6: its coefficients (calibrate --store-result) and a passing verdict.
result(6, "verdict", {"pass": True, "rows": []})
result(6, "report", ok_report)
db.commit()
PY

expect 0 "^verdict: PASS" "$bin" results 1 --db "$db"
expect 4 "run 2: FAIL \(exit 4\)" "$bin" results 2 --db "$db"
expect 5 "run 3: no PASS/FAIL verdict: undetermined \(exit 5\)" "$bin" results 3 --db "$db"
# --truth without coefficients (the failed calibration of the issue): not 0, not an error.
expect 5 "no coefficients stored: nothing to compare" "$bin" results 3 --db "$db" --truth "$truth"
expect 5 "no verdict \(no acceptance limits\)" "$bin" results 4 --db "$db"
expect 5 "undetermined" "$bin" results 4 --db "$db" --json
expect 4 "FAIL" "$bin" results 2 --db "$db" --json
expect 1 "run 5 \(plan direct_two_axis\) is interrupted, stopped in step 2 \(rate_z_up_pos\) after step 1 finished: the daemon stopped .*t = 42.000000 s; .imubench resume 5. goes on from its last finished step; no results stored" \
  "$bin" results 5 --db "$db"
expect 1 "run 99" "$bin" results 99 --db "$db"
# --truth with coefficients: exit 0 only when every parameter is within its target and none
# is held; a held parameter (not determined) makes it undetermined.
set +e
out=$("$bin" results 6 --db "$db" --truth "$truth" 2>&1); code=$?
set -e
printf '%s\n' "$out"
if printf '%s\n' "$out" | grep -q "OUTSIDE"; then want=4
elif printf '%s\n' "$out" | grep -q "held (not judged)"; then want=5
else want=0; fi
[ "$code" = "$want" ] || fail "results 6 --truth: exit $code, expected $want"
python3 - "$db" <<'PY'
import json, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
rid, doc = db.execute("SELECT id, json FROM results WHERE run_id = 6 AND kind = 'coefficients'").fetchone()
c = json.loads(doc)
# gyro.bias.x held at its start value (interchange.md: "observable": false, no sigma).
c["gyro"].setdefault("observable", {})["bias"] = [False, True, True]
c["gyro"]["sigma"]["bias"][0] = None
db.execute("UPDATE results SET json = ? WHERE id = ?", (json.dumps(c), rid))
db.commit()
PY
set +e
out=$("$bin" results 6 --db "$db" --truth "$truth" 2>&1); code=$?
set -e
printf '%s\n' "$out"
printf '%s\n' "$out" | grep -q "held (not judged)" || fail "results 6: the held parameter is not shown"
if printf '%s\n' "$out" | grep -q "OUTSIDE"; then want=4; else want=5; fi
[ "$code" = "$want" ] || fail "results 6 --truth with a held parameter: exit $code, expected $want"
echo "PASS"
