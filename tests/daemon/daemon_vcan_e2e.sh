#!/usr/bin/env bash
# Runs under tools/vcan-run.sh (vcan0 exists). The whole product on one machine: the virtual
# bench (table and chamber over Modbus TCP, IMU frames on vcan0), imubenchd with a bench file
# pointing at it, and a client on the control socket (python3, stdlib only). Checks:
#   a plan runs to "finished" with step events; a second start while busy is refused (busy);
#   the stored run exports as imubench-csv/1 with the plan's segments and IMU samples without
#   loss; pause + resume mid-plan finishes; abort ends "aborted"; emergency stop ends
#   "faulted"; a malformed request gets an error and the daemon keeps answering.
# Then the operator's CLI against the same daemon: `imubench start PLAN --watch` follows a run
# to completion (exit 0), `imubench status` answers, `imubench export` of the stored run works.
# Usage: daemon_vcan_e2e.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
E2E_BENCH_EXTRA="plan_dir = \"$SRC/tests/daemon/data\"" e2e_bench_file
e2e_start_vb --time-scale 5
e2e_start_daemon

"$CLI" start "$SRC/tests/daemon/data/smoke_plan.toml" --label cli --watch >"$W/watch.out" 2>&1 ||
  { cat "$W/watch.out"; fail "imubench start --watch did not end in a completed run"; }
tail -3 "$W/watch.out"
"$CLI" status || fail "imubench status"
"$CLI" export 1 --csv "$W/export0" --db "$W/imubench.db" || fail "imubench export of run 1"
[[ -s $W/export0/imu.csv && -s $W/export0/segments.csv ]] || fail "exported run 1 is incomplete"
echo "ok: the imubench CLI started, watched and exported a run"

python3 - "$W" "$SRC/tests/daemon/data/smoke_plan.toml" <<'PY' || fail "client checks"
import csv, json, socket, sys, time

work, plan = sys.argv[1], sys.argv[2]
sock = socket.socket(socket.AF_UNIX)
sock.connect(work + "/control.sock")
sock.settimeout(150)  # longer than any wait below: a stall is reported by wait_event
# Read-only: a text file object opened "rw" drops the lines it has read ahead whenever it is
# written to (CPython's TextIOWrapper.write resets its decoder); requests go out by sendall.
f = sock.makefile("r", encoding="utf-8")
events = []
seen = []  # every line received, for a failure's message

def send(obj):
    sock.sendall(((obj if isinstance(obj, str) else json.dumps(obj)) + "\n").encode("utf-8"))

def reply(obj):
    send(obj)
    while True:
        line = json.loads(f.readline())
        seen.append(line)
        if "event" in line:
            events.append(line)
        else:
            return line

def wait_event(pred, what, limit=120):
    end = time.time() + limit
    for e in events:
        if pred(e):
            events.remove(e)
            return e
    while time.time() < end:
        e = json.loads(f.readline())
        seen.append(e)
        if "event" not in e:
            continue
        if pred(e):
            return e
        events.append(e)
    raise SystemExit("timed out waiting for %s; events: %s" % (what, events[-10:]))

def check(cond, what):
    if not cond:
        raise SystemExit("check failed: " + what)
    print("ok:", what)

r = reply({"id": 1, "cmd": "subscribe", "topics": ["run"]})
check(r["ok"], "subscribe")
bad = reply('{"id": 2, "cmd": "start", "plan": ')
check(not bad["ok"] and bad["error"]["code"] == "bad_json", "malformed request refused")
start = reply({"id": 3, "cmd": "start", "plan": {"path": plan}})
check(start["ok"], "start: " + json.dumps(start))
run1 = start["result"]["run"]
busy = reply({"id": 4, "cmd": "start", "plan": {"path": plan}})
check(not busy["ok"] and busy["error"]["code"] == "busy", "second start while busy refused")
st = reply({"id": 5, "cmd": "status"})
check(st["ok"] and st["result"]["state"] == "running", "status running")
fin = wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run1, "run 1 end")
check(fin["state"] == "finished" and fin["exit"] == "completed", "run 1 completed")
started = [e["label"] for e in events if e["event"] == "step_started"]
check(started == ["h1", "r1", "h2"], "step events in order: %s (received: %s)" %
      (started, "; ".join(json.dumps(x) for x in seen[-30:])))
events.clear()

exp = reply({"id": 6, "cmd": "export", "run": run1, "dir": "export1"})
check(exp["ok"] and exp["result"]["dir"] == work + "/exports/export1", "export: " + json.dumps(exp))
with open(work + "/exports/export1/segments.csv") as fh:
    segs = list(csv.DictReader(fh))
check([s["kind"] for s in segs] == ["static", "rotate", "static"], "segments stored")
hold = float(segs[0]["t1"]) - float(segs[0]["t0"])
check(4.9 < hold < 6.0, "hold measured on the IMU clock: %.3f s of 5 s" % hold)
with open(work + "/exports/export1/imu.csv") as fh:
    rows = [l for l in fh if l[0].isdigit() or l[0] == "-"]
ts = [float(l.split(",")[0]) for l in rows]
gaps = sum(1 for a, b in zip(ts, ts[1:]) if b - a > 0.0015)
check(len(ts) > 10000 and gaps == 0, "%d IMU samples stored, no gaps" % len(ts))
st = reply({"id": 7, "cmd": "status"})
check(st["result"]["imu_lost_samples"] == 0, "no IMU samples lost")

# Pause mid-plan, resume, finish.
start = reply({"id": 8, "cmd": "start", "plan": {"path": plan}})
run2 = start["result"]["run"]
wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1", "r1 start")
check(reply({"id": 9, "cmd": "pause"})["ok"], "pause")
check(not reply({"id": 10, "cmd": "pause"})["ok"], "pause while paused refused")
check(reply({"id": 11, "cmd": "resume"})["ok"], "resume")
fin = wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run2, "run 2 end")
check(fin["exit"] == "completed", "paused and resumed run completed")

# Abort.
run3 = reply({"id": 12, "cmd": "start", "plan": {"path": plan}})["result"]["run"]
check(reply({"id": 13, "cmd": "abort"})["ok"], "abort")
fin = wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run3, "run 3 end")
check(fin["state"] == "aborted", "aborted run closed as aborted")

# Emergency stop.
run4 = reply({"id": 14, "cmd": "start", "plan": {"path": plan}})["result"]["run"]
check(reply({"id": 15, "cmd": "stop"})["ok"], "emergency stop")
fin = wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run4, "run 4 end")
check(fin["state"] == "faulted" and fin["exit"] == "emergency_stop", "emergency stop closes faulted")

hist = reply({"id": 16, "cmd": "results"})
states = [r["state"] for r in hist["result"]["runs"]]
check(states == ["finished", "finished", "finished", "aborted", "faulted"], "run history %s" % states)
bad = reply({"id": 18, "cmd": "start", "plan": {"path": plan}})
check(not bad["ok"] and "emergency stop" in bad["error"]["message"] and
      len(reply({"id": 19, "cmd": "results"})["result"]["runs"]) == 5,
      "no start on a table still in emergency stop: " + bad["error"]["message"])
check(reply({"id": 17, "cmd": "ping"})["ok"], "still answering")
PY
if grep "ALARM" "$W/d.out" | grep -qv "emergency stop"; then fail "unexpected alarm in the daemon log"; fi
e2e_stop_daemon
echo "PASS"
