#!/usr/bin/env bash
# Issue 15: the plan queue through the real imubenchd on vcan, driven by the imubench CLI and
# the Python client:
#   - two plans queued behind a running one (`imubench start --queue`), a plan the bench
#     refuses is not queued (bad_plan at enqueue time); reorder (`queue move`), remove one
#     (`queue remove`): the remaining one starts by itself when the first completes;
#   - one more queued, SIGTERM, the daemon started again on the same database: `imubench
#     queue` still lists it and nothing started by itself; `queue resume` starts it;
#   - after an abort the queue holds (the next plan does not start); a queued plan the bench
#     cannot start (table in emergency stop) stays queued.
# Usage: queue.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"

for name in first second third fourth fifth; do
  sed "s/^name = \"smoke\"/name = \"$name\"/" "$SRC/tests/daemon/data/smoke_plan.toml" >"$W/$name.toml"
done
sed 's/^max_rate = "20 deg\/s"/max_rate = "200 deg\/s"/' "$W/second.toml" >"$W/too_fast.toml"

e2e_bench_file
e2e_start_vb --time-scale 5
e2e_start_daemon

PYTHONPATH="$SRC/tools/python" e2e_py "$CLI" <<'PY' || fail "queue behind a running plan"
import subprocess, sys
from e2e_client import Client, check
import imubench_client
work, cli = sys.argv[1], sys.argv[2]

def imubench(*args, ok=True):
    p = subprocess.run([cli, *args], capture_output=True, text=True)
    check((p.returncode == 0) == ok, "imubench %s -> exit %d: %s%s"
          % (" ".join(args), p.returncode, p.stdout.strip(), p.stderr.strip()))
    return p.stdout + p.stderr

c = Client(work + "/control.sock")
c.subscribe("run")
out = imubench("start", work + "/first.toml")
check("started run 1" in out, "first plan runs")
# Held paused while the queue is edited, so the checks below do not race the plan's end on a
# fast (or slow) machine; resumed before waiting for it to complete.
check(c.reply({"cmd": "pause"})["ok"], "pause run 1")
c.wait_event(lambda e: e["event"] == "state" and e["state"] == "paused", "paused")
out = imubench("start", "--queue", work + "/second.toml")
check("queued as entry 1 at position 1 (plan second)" in out, "second queued: " + out.strip())
out = imubench("start", "--queue", work + "/third.toml")
check("queued as entry 2 at position 2 (plan third)" in out, "third queued: " + out.strip())
out = imubench("start", "--queue", work + "/too_fast.toml", ok=False)
check("error (bad_plan)" in out, "a plan the bench refuses is not queued")
check(imubench("start", work + "/fourth.toml", ok=False).find("error (busy)") >= 0,
      "a start without --queue is still busy")

with imubench_client.Client(work + "/control.sock") as py:
    q = py.queue_list()
    check([(e["entry"], e["position"], e["plan"]) for e in q] == [(1, 1, "second"), (2, 2, "third")],
          "queue_list: %s" % q)
    check(q[0]["name"] == work + "/second.toml", "an entry names its file")
    try:
        py.queue_move(2, 3)
        check(False, "a position beyond the queue is refused")
    except imubench_client.RemoteError as e:
        check(e.code == "bad_argument", "position beyond the queue: " + e.message)
    try:
        py.queue_remove(99)
        check(False, "an unknown entry is refused")
    except imubench_client.RemoteError as e:
        check(e.code == "not_found" and "queue entry 99" in e.message, "unknown entry: " + e.message)
    try:
        py.queue_resume()
        check(False, "queue_resume while a run is going (paused) is refused")
    except imubench_client.RemoteError as e:
        check(e.code == "bad_state", "queue_resume while running: " + e.message)

out = imubench("queue", "move", "2", "1")
check(out.index("third") < out.index("second"), "reordered: third first\n" + out)
out = imubench("queue", "remove", "1")
check("second" not in out and "third" in out, "second removed\n" + out)
out = imubench("queue")
check(out.splitlines()[1].split()[:3] == ["1", "2", "third"], "imubench queue:\n" + out)
check(c.reply({"cmd": "status"})["result"]["queued"] == 1, "status counts the queue")
check(c.reply({"cmd": "resume"})["ok"], "resume run 1")

end = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == 1, "run 1 end")
check(end["exit"] == "completed", "first plan completed")
started = c.wait_event(lambda e: e["event"] == "queue_started", "queue start", 30)
check(started["entry"] == 2 and started["plan"] == "third" and started["run"] == 2,
      "the remaining queued plan starts by itself: %s" % started)
check(c.reply({"cmd": "queue_list"})["result"]["queue"] == [], "the queue is empty")
st = c.reply({"cmd": "status"})["result"]
check(st["run"] == 2 and st["plan"] == "third", "run 2 is third")
out = imubench("start", "--queue", work + "/fourth.toml")
check("queued as entry 3 at position 1 (plan fourth)" in out, "fourth queued behind run 2")
PY

# SIGTERM while run 2 goes (the daemon cuts it): the queue is stored; after the restart it is still
# there and holds (nothing starts by itself) until `queue resume`.
e2e_stop_daemon
e2e_start_daemon
PYTHONPATH="$SRC/tools/python" e2e_py "$CLI" <<'PY' || fail "the queue after a restart"
import subprocess, sys, time
from e2e_client import Client, check
work, cli = sys.argv[1], sys.argv[2]

def imubench(*args):
    p = subprocess.run([cli, *args], capture_output=True, text=True)
    check(p.returncode == 0, "imubench %s: %s%s" % (" ".join(args), p.stdout.strip(), p.stderr.strip()))
    return p.stdout

out = imubench("queue")
check(out.splitlines()[1].split()[:3] == ["1", "3", "fourth"],
      "after the restart imubench queue still lists fourth:\n" + out)
c = Client(work + "/control.sock")
c.subscribe("run")
runs = c.reply({"cmd": "results"})["result"]["runs"]
check([r["state"] for r in runs][:1] == ["finished"] and len(runs) == 2 and
      runs[1]["state"] == "interrupted", "run 2 was cut by the SIGTERM (resumable): %s" % runs[1])

def stays_idle(what):
    # Bounded poll over 2 s: the bench stays idle with one plan queued (nothing starts).
    for _ in range(10):
        st = c.reply({"cmd": "status"})["result"]
        if st["state"] != "idle" or st["queued"] != 1:
            check(False, what + ": %s" % st)
        time.sleep(0.2)
    check(True, what)

stays_idle("after the restart the queue holds")
out = imubench("queue", "resume")
check("started queue entry 3 as run 3 (plan fourth)" in out, "queue resume: " + out.strip())
out = imubench("start", "--queue", work + "/fifth.toml")
check("queued as entry 4" in out, "fifth queued behind run 3")
check(c.reply({"cmd": "abort"})["ok"], "abort run 3")
end = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == 3, "run 3 end", 60)
check(end["state"] == "aborted", "run 3 aborted")
stays_idle("after an abort the queue holds")
check(not any(e["event"] == "queue_started" and e["entry"] == 4 for e in c.events),
      "fifth (entry 4) never started")
# A queued plan the bench cannot start now (table in emergency stop) stays queued.
check(c.reply({"cmd": "stop"})["ok"], "emergency stop with no run")
r = c.reply({"cmd": "queue_resume"})
check(not r["ok"] and r["error"]["code"] == "bad_state" and
      r["error"]["message"].startswith("queue entry 4 (plan 'fifth'): ") and
      "emergency stop" in r["error"]["message"], "queue resume on a stopped table: %s" % r["error"])
q = c.reply({"cmd": "queue_list"})["result"]["queue"]
check([e["entry"] for e in q] == [4], "the entry stays queued")
PY
e2e_stop_daemon
echo "PASS"
