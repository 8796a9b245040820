#!/usr/bin/env bash
# Issue 28 item 7, must show: every Modbus round trip of the virtual bench takes 20 +- 5 ms
# (--modbus-latency-ms 20 --modbus-jitter-ms 5, half each way), the IMU runs on its own CAN
# clock, and a direct plan (calibration = "direct") runs through the real imubenchd at time
# scale SCALE (1 or 20). A table reading stamped when its request left lags the table by the
# latency times the time scale (10 ms at 1x, 0.2 s of bench time at 20x): a table-IMU time
# offset the missing-physics analysis would name as time_delay. Stamped at the reading's
# instant on the IMU clock (issue 28 item 6), checks:
#   - the run completes and its end-of-plan results are stored: coefficients, verdict PASS
#     against the bench file's [acceptance] limits (tools/demo_bench_limits.toml), and the
#     missing-physics report (imubench-explain/1), which names no time_delay among the effects
#     it accepts or cannot separate;
#   - `imubench results RUN` exits 0 (PASS);
#   - every table reading is stored with its read round trip (median 15-40 ms).
# At 1x the bundled direct plan would take 30 min: the plan here is the bundled one with
# shorter holds (30 s positions, 10 s around the rate runs) and one-turn rate runs (3 s ramp,
# 9 s at 30 deg/s, 3 s ramp: 360 deg) — the same positions, axes and directions, about 10 min
# (with 15 s positions the verdict sat too close to the acceptance limits: one of two runs
# failed it).
# At 20x the bundled plan as it is (about 1.5 min).
# Usage: table_latency.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir> SCALE
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
SCALE=${5:?time scale}
[[ -n ${E2E_KEEP:-} ]] && trap 'cp "$W"/imubench.db* "$W"/d.out "$E2E_KEEP/" 2>/dev/null; e2e_cleanup' EXIT

e2e_navgrade_bench
if [[ $SCALE == 1 ]]; then
  "$SRC/tests/daemon/e2e/shorten_direct_plan.sh" "$W/direct.toml" || fail "short plan"
fi
# The table's certified errors (the truth's table section): the direct method takes them as
# known, so its fit reaches the noise and the run gets a verdict (without them: no verdict,
# online.sh).
E2E_TABLE_EXTRA="errors = \"$TRUTH\""
e2e_bench_file "$(cat "$SRC/tools/demo_bench_limits.toml")"
e2e_start_vb --time-scale "$SCALE" --truth "$TRUTH" --noise nav-grade --seed 5 \
  --modbus-latency-ms "${E2E_LATENCY_MS:-20}" --modbus-jitter-ms "${E2E_JITTER_MS:-5}"
e2e_start_daemon

PYTHONPATH="$SRC/tools/python" e2e_py "$CLI" <<'PY' || fail "latency run"
import json, sqlite3, statistics, subprocess, sys
from e2e_client import Client, check
work, cli = sys.argv[1], sys.argv[2]
c = Client(work + "/control.sock", timeout=900.0)
c.subscribe("run")
p = subprocess.run([cli, "start", work + "/direct.toml"], capture_output=True, text=True, timeout=60)
check(p.returncode == 0 and "started run" in p.stdout, "imubench start: " + p.stdout + p.stderr)
run = int(p.stdout.split("started run ")[1].split()[0])
e = c.wait_event(lambda e: e.get("run") == run and e["event"] == "results", "results", 900)
gaps = [g["message"] for g in c.events if g["event"] == "recording_gap"]
print("recording gaps:", gaps, flush=True)
check(e["ok"] and e["calibrated"], "results stored: %s" % e)
stored = {r["kind"]: r["json"] for r in c.reply({"cmd": "results", "run": run})["result"]["results"]}
if e["pass"] is not True:
    # What the verdict and the direct fit say, so a failure names its cause.
    v, rep = stored.get("verdict", {}), stored.get("report", {})
    print("verdict why:", v.get("why"), "findings:", json.dumps(v.get("findings")), flush=True)
    print("direct fit:", json.dumps(rep.get("direct")), flush=True)
check(e["pass"] is True, "verdict PASS against the acceptance limits: %s" % e)
x = stored.get("explain", {})
check(x.get("format") == "imubench-explain/1", "explain stored as imubench-explain/1")
accepted = [a["effect"] for a in x.get("accepted", [])]
for a in x.get("accepted", []):
    print("accepted %s: %s +- %s" % (a["effect"], json.dumps(a.get("parameters")), json.dumps(a.get("sigma"))), flush=True)
unseparable = json.dumps(x.get("unseparable", []))
print("explain accepts:", accepted, flush=True)
td = [r for r in x.get("rejected", []) if r.get("effect") == "time_delay"]
print("explain on time_delay:", td, flush=True)
check("time_delay" not in accepted, "explain names no time_delay: accepted %s" % accepted)
check("time_delay" not in unseparable, "time_delay not among the unseparable: %s" % unseparable)
db = sqlite3.connect(work + "/imubench.db")
trips = [r for (r,) in db.execute("SELECT round_trip_s FROM table_samples WHERE run_id = ?", (run,))]
check(trips and all(r is not None for r in trips), "every table reading has its round trip")
med = statistics.median(trips)
print("table reads: %d, round trip median %.1f ms" % (len(trips), 1e3 * med), flush=True)
check(0.015 <= med <= 0.040, "round trips match the injected 20 +- 5 ms: median %.1f ms" % (1e3 * med))
open(work + "/run", "w").write(str(run))
PY

run=$(cat "$W/run")
# The stored verdict through the CLI: exit 0 is PASS (a direct plan alone does not reach the
# truth's 3 arcsec / 10 ppm on a table with errors: resume_calibration.sh, online.sh).
rc=0
out=$("$CLI" results "$run" --db "$W/imubench.db" 2>&1) || rc=$?
echo "$out"
[[ $rc == 0 ]] && grep -q '^verdict: PASS' <<<"$out" || fail "results $run: verdict PASS (exit $rc)"
e2e_stop_daemon
echo PASS
