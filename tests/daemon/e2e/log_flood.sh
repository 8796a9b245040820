#!/usr/bin/env bash
# Issue 17, defect 8, through the real imubenchd on vcan: with a run in progress the virtual
# bench (table, chamber and IMU) goes away for 60 s. The daemon's log over those 60 s holds
# fewer than 30 lines, at least one of them at warning or error level about the table (the
# drivers fail on every 20 ms poll: repeated failures are logged once, then summarised). When
# the bench is back, the end of the table's failures is logged.
# Usage: log_flood.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
e2e_start 1

e2e_py "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "start"
import sys
from e2e_client import start_run

work, plan = sys.argv[1], sys.argv[2]
c = start_run(work, plan)
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "h1", "step h1", 30)
c.close()
PY

before=$(wc -l <"$W/d.out")
e2e_stop_vb
sleep 60  # the fault's duration: what the daemon logs meanwhile is what is under test
tail -n +$((before + 1)) "$W/d.out" >"$W/fault.log"
lines=$(wc -l <"$W/fault.log")
echo "--- the daemon's log over the 60 s without the bench ($lines lines)"
cat "$W/fault.log"
((lines < 30)) || fail "$lines log lines in 60 s of a failing table (at most 29)"
grep -Eq '^imubenchd: (warning|error): .*REF-2' "$W/fault.log" ||
  fail "no warning or error about the table"
grep -Eq 'table: [0-9]+ more like this in the last' "$W/fault.log" ||
  fail "the table's repeated failures are not summarised"
echo "ok: $lines log lines in 60 s of a failing table, at warning level, summarised"

e2e_start_vb --time-scale 1
for _ in $(seq 300); do
  grep -q 'notice: table: no more messages for' "$W/d.out" && break
  sleep 0.1
done
grep -q 'notice: table: no more messages for' "$W/d.out" ||
  fail "the end of the table's failures is not logged"
echo "ok: the end of the table's failures is logged"
e2e_stop_daemon
echo PASS
