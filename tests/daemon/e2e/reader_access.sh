#!/usr/bin/env bash
# Issue 28 item 9: what a reader (bench file [control] read_group) can read, and a progress
# figure that never goes back. Runs under tools/vcan-run.sh (virtual bench + imubenchd) with
# command group daemon and read group nogroup (as rights.sh); the reader is nobody (uid 65534,
# primary group nogroup):
#   - the database and its -wal/-shm are 0640 with group nogroup; nobody runs
#     `imubench export RUN --db` (reads the store itself);
#   - an export through the socket (as nobody) lands 0750/0640 with group nogroup: nobody
#     reads its files;
#   - a user refused by the socket's mode is told the socket's group (not a fixed "imubench");
#   - a plan paused inside its rotation and resumed (the step re-runs): every progress figure
#     the daemon sends (status replies and progress events) is >= the one before.
# Usage: reader_access.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
TMPDIR=/tmp e2e_init "$@"
[[ $(id -u) == 0 ]] || fail "needs root (runs inside user-mode-linux as root) to switch users"
chmod 0755 "$W"
e2e_bench_file '[control]
command_group = "daemon"
read_group = "nogroup"'
e2e_start 2
chmod 0666 "$W/control.sock"
for f in "$W/imubench.db" "$W/imubench.db-wal" "$W/imubench.db-shm"; do
  [[ ! -e $f || $(stat -c '%a %G' "$f") == "640 nogroup" ]] ||
    fail "$f is $(stat -c '%a %U:%G' "$f"), not 0640 group nogroup"
done
echo "ok: the database is 0640, group nogroup"

# 1. Progress across a pause inside the rotation (the step re-runs on resume).
e2e_py "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "monotonic progress"
import sys, time
from e2e_client import Client, check, plan_file
work, plan = sys.argv[1], sys.argv[2]
c = Client(work + "/control.sock")
c.subscribe("run", "status")
run = c.reply({"cmd": "start", "plan": plan_file(plan)})["result"]["run"]
# Status replies and progress events in the order each arrived (the two interleave on the
# wire; each must be monotonic on its own).
replies, events = [], []
def status():
    p = c.reply({"cmd": "status"})["result"].get("progress")
    if p is not None:
        replies.append(p)
def progress_event(limit):
    e = c.wait_event(lambda e: e["event"] in ("progress", "run_finished") and e["run"] == run,
                     "progress or end", limit)
    if e["event"] == "progress":
        events.append(e["progress"])
    return e
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "rotation")
# Deep into the rotation, so its re-run from the start lowers the planned-time figure.
while progress_event(30)["progress"] <= 0.5:
    status()
status()
check(c.reply({"cmd": "pause"})["ok"], "pause inside the rotation")
c.wait_event(lambda e: e["event"] == "state" and e["state"] == "paused", "paused")
status()
check(c.reply({"cmd": "resume"})["ok"], "resume (the rotation re-runs)")
while progress_event(60)["event"] != "run_finished":
    status()
for name, seen in (("status replies", replies), ("progress events", events)):
    back = [(a, b) for a, b in zip(seen, seen[1:]) if b < a]
    check(len(seen) > 5 and not back,
          "%d %s, none below the one before: %s" % (len(seen), name, back[:3]))
PY

# 2. A reader's exports and the database.
# (Created for nobody here: under user-mode-linux /tmp is the host's (hostfs), where what a
# process creates belongs to the host's user whatever its uid inside.)
mkdir -p "$W/nobody-out/run1"
chown -R 65534:65534 "$W/nobody-out"
e2e_py 65534 <<'PY' || fail "reader's export"
import os, sys
from e2e_client import Client, check
work = sys.argv[1]
os.setgroups([]); os.setgid(int(sys.argv[2])); os.setuid(int(sys.argv[2]))
c = Client(work + "/control.sock")
r = c.reply({"cmd": "export", "run": 1, "dir": "mine"})
check(r["ok"], "nobody may export: %s" % r)
d = r["result"]["dir"]
with open(d + "/imu.csv") as f:
    check(len(f.readline()) > 0, "nobody reads its export " + d + "/imu.csv")
check(len(os.listdir(d)) > 2, "nobody lists its export: %s" % os.listdir(d))
PY
[[ $(stat -c '%a %G' "$W/exports/mine") == "750 nogroup" ]] || fail "export dir $(stat -c '%a %G' "$W/exports/mine")"
[[ $(stat -c '%a %G' "$W/exports/mine/imu.csv") == "640 nogroup" ]] || fail "export file mode"
setpriv --reuid=65534 --regid=65534 --clear-groups \
  "$CLI" export 1 --csv "$W/nobody-out/run1" --db "$W/imubench.db" ||
  fail "nobody cannot export --db"
[[ -s $W/nobody-out/run1/imu.csv ]] || fail "export --db wrote no imu.csv"
echo "ok: nobody exports run 1 from the database itself"

# 3. Refused by the socket's mode: the message names the socket's group.
chgrp daemon "$W/control.sock"
chmod 0660 "$W/control.sock"
out=$(setpriv --reuid=12345 --regid=12345 --clear-groups "$CLI" status 2>&1) && fail "uid 12345 reached a 0660 socket"
echo "$out"
grep -q "mode 0660, group daemon (are you in group daemon?)" <<<"$out" ||
  fail "the permission message does not name the socket's group"
grep -q "group imubench" <<<"$out" && fail "the permission message names a fixed group"
chmod 0666 "$W/control.sock"
e2e_stop_daemon
echo "PASS"
