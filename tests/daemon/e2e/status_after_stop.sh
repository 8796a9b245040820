#!/usr/bin/env bash
# Issue 28, item 6, through the real processes on vcan: the daemon polls the table whenever it
# runs, not only during a run. An emergency stop (`imubench stop`) in the middle of a
# rotation ends the run; once the controller's registers (read by a third-party Modbus
# client, modbus_peek.py) show the axis at rest with the emergency stop latched, `status`
# shows the same within a few polls: moving false, estop true, the same angles; every reply
# says how old its table reading is (table.age_s, within a few 20 ms polls); `imubench status
# --json` too.
# Usage: status_after_stop.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

{
  e2e_plan_head stop "status after an emergency stop"
  e2e_hold h1 "1 s"
  e2e_rotate r1 outer "180 deg" +
  e2e_hold h2 "1 s"
} >"$W/plan.toml"

e2e_bench_file "$E2E_SLOW_IMU"
e2e_start 2

e2e_py "$CLI" "$E2E_TABLE_DEVICE" "$W/plan.toml" <<'PY' || fail "status after stop"
import json, subprocess, sys, time
from e2e_client import check, start_run
from modbus_peek import TablePeek
work, cli, device, plan = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
peek = TablePeek(device, 1502)
c = start_run(work, plan)
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "r1 start", 60)
end = time.monotonic() + 30
while not peek.read()["moving"][0] and time.monotonic() < end:
    time.sleep(0.02)
check(peek.read()["moving"][0], "the outer axis turns")
p = subprocess.run([cli, "stop"], capture_output=True, text=True, timeout=30)
check(p.returncode == 0, "imubench stop: %s%s" % (p.stdout, p.stderr))
# The controller: braked to rest (at most 10 deg/s at 100 deg/s^2), emergency stop latched.
end = time.monotonic() + 30
while time.monotonic() < end:
    reg = peek.read()
    if reg["estop"] and not any(reg["moving"]):
        break
    time.sleep(0.01)
seen = time.monotonic()
check(reg["estop"] and not any(reg["moving"]), "the controller at rest, estop set: %s" % reg)

def matches(t):
    return (t.get("moving") is False and t["estop"] and "angles_deg" in t and
            all(abs(a - b) < 1e-3 for a, b in zip(t["angles_deg"], reg["angles_deg"])))

# The run is over: no runner polls the table any more, the daemon still does.
ages = []
while True:
    st = c.reply({"cmd": "status"})["result"]
    check("age_s" in st["table"], "status says how old its table reading is: %s" % st["table"])
    ages.append(st["table"]["age_s"])
    if matches(st["table"]) or time.monotonic() > seen + 5.0:
        break
took = time.monotonic() - seen
check(st["state"] == "idle", "no run after the emergency stop: %s" % st["state"])
check(matches(st["table"]), "status matches the controller (moving false, estop true, angles "
      "%s): %s" % (reg["angles_deg"], st["table"]))
check(took < 0.25, "within a few polls of the controller's state: %.3f s" % took)
# Fresh while idle: every reply's reading is at most a few polls old.
for _ in range(20):
    st = c.reply({"cmd": "status"})["result"]
    ages.append(st["table"]["age_s"])
    time.sleep(0.01)
check(max(ages) < 0.1 and min(ages) >= 0.0,
      "table.age_s of %d idle status replies in [%.3f, %.3f] s (20 ms polls)"
      % (len(ages), min(ages), max(ages)))
p = subprocess.run([cli, "status", "--json"], capture_output=True, text=True, timeout=30)
check(p.returncode == 0, "imubench status --json: %s" % p.stderr)
doc = json.loads(p.stdout.splitlines()[0])
t = doc.get("result", doc)["table"]
check(matches(t) and t["age_s"] < 0.1, "imubench status --json: %s" % t)
PY
e2e_stop_daemon
echo "PASS"
