#!/usr/bin/env bash
# Issue 17, defect 2: the emergency stop cannot be locked out by idle connections, and idle
# connections time out. Runs under tools/vcan-run.sh (virtual bench + imubenchd).
#   1. A plan is rotating the table; 16 connections (the client limit) are open and idle. A
#      17th connection still gets `stop` through (a reserved slot): the reply and the run's end
#      (faulted, emergency_stop) arrive within 0.5 s on the wall clock, and the table's
#      controller is latched in its emergency stop (the next start is refused for it). The
#      reserved connection takes stop/status/ping only.
#   2. With `[control] idle_timeout = "1 s"` in the bench file: idle connections are closed
#      after about that long and their slots are free again; subscribed watchers are kept, one
#      reading events of a running plan and one waiting quietly with no run.
# Usage: client_slots.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

e2e_start 2

e2e_py "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "reserved slot checks"
import socket, sys, time
from e2e_client import Client, check, start_run

work, plan = sys.argv[1], sys.argv[2]
sock = work + "/control.sock"
watcher = start_run(work, plan)
run = watcher.run
watcher.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "rotation")

idle = []
for i in range(15):  # with the watcher: all 16 regular slots taken, nobody says anything
    idle.append(Client(sock))
idle[-1].reply({"cmd": "ping"})  # the last of them is accepted: all slots are taken now

t0 = time.monotonic()
stopper = Client(sock)
r = stopper.reply({"cmd": "stop"})
t_reply = time.monotonic() - t0
check(r["ok"], "stop through the 17th connection: %s" % r)
fin = watcher.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end",
                         limit=5)
t_end = time.monotonic() - t0
check(fin["state"] == "faulted" and fin["exit"] == "emergency_stop", "run ended by the stop")
check(t_reply < 0.5 and t_end < 0.5,
      "stop answered after %.3f s, run closed after %.3f s (< 0.5 s)" % (t_reply, t_end))
check(stopper.reply({"cmd": "status"})["result"]["state"] == "idle", "status in a reserved slot")
busy = stopper.reply({"cmd": "results"})
check(not busy["ok"] and busy["error"]["code"] == "busy" and
      "reserved slot" in busy["error"]["message"], "a reserved slot takes nothing else")
again = watcher.reply({"cmd": "start", "plan": {"toml": open(plan).read()}})
check(not again["ok"] and "emergency stop" in again["error"]["message"],
      "the table's controller is in emergency stop: " + again["error"]["message"])
for c in idle + [stopper, watcher]:
    c.close()
PY
e2e_stop_daemon
grep -q "into a reserved slot" "$W/d.out" || fail "the daemon log does not name the reserved slot"

# 2. A short idle timeout. The virtual bench's table is still in its emergency stop: restart it.
e2e_stop_vb
e2e_start_vb --time-scale 2
e2e_bench_file '[control]
idle_timeout = "1 s"'
e2e_start_daemon
e2e_py "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "idle timeout checks"
import select, socket, sys, time
from e2e_client import Client, check

work, plan = sys.argv[1], sys.argv[2]
sock = work + "/control.sock"
quiet = Client(sock)
quiet.subscribe("run")          # waits for a run that has not started: listens, never idle
reader = Client(sock)
reader.subscribe("run", "status")
idle = [Client(sock) for _ in range(14)]
t0 = time.monotonic()
closed_after = []
for c in idle:
    ready, _, _ = select.select([c.sock], [], [], 10)
    check(ready and c.sock.recv(1) == b"", "an idle connection is closed by the daemon")
    closed_after.append(time.monotonic() - t0)
check(0.5 < max(closed_after) < 3.5,
      "idle connections closed after %.2f..%.2f s (timeout 1 s)" % (min(closed_after), max(closed_after)))
# Their slots are free: 14 new connections take full commands (a reserved slot would refuse
# subscribe).
fresh = [Client(sock) for _ in range(14)]
check(all(c.reply({"cmd": "subscribe", "topics": ["log"]})["ok"] for c in fresh),
      "the freed slots take new clients")
run = fresh[0].reply({"cmd": "start", "plan": {"toml": open(plan).read()}})["result"]["run"]
for c in fresh:
    c.close()
# The reader follows the run for several idle timeouts, reading only.
n = 0
t1 = time.monotonic()
while time.monotonic() - t1 < 4.0:
    e = reader.wait_event(lambda e: True, "an event", limit=5)
    n += 1
check(n >= 3, "the reading watcher got %d events over 4 s and was kept" % n)
check(reader.reply({"cmd": "ping"})["ok"], "the reading watcher is still connected")
e = quiet.wait_event(lambda e: e["event"] == "step_started", "the quiet watcher's first event")
check(e["run"] == run, "the quiet watcher (subscribed %.1f s ago) is still connected"
      % (time.monotonic() - t0))
check(reader.reply({"cmd": "abort"})["ok"], "abort")
reader.wait_event(lambda e: e["event"] == "run_finished", "run end")
PY
grep -q "idle for 1 s" "$W/d.out" || fail "the daemon log does not say why idle clients went"
e2e_stop_daemon
echo "PASS"
