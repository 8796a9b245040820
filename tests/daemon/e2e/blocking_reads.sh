#!/usr/bin/env bash
# Issue 17, defect 3: no plan file a client names can block the daemon's event loop. Runs
# under tools/vcan-run.sh (virtual bench + imubenchd). Three bad files, each both inside the
# bench's plan library (plan_dir, read by the daemon off its loop) and outside it (refused
# untouched):
#   a FIFO without a writer (a blocking open never returns),
#   a stalled file: a regular file under a write lease another process holds and never gives
#     up (a blocking open waits for the lease break, 45 s by default; like a file on a hung
#     network file system),
#   a 100 MB plan file.
# validate_plan of each while a plan runs, then start of each with the bench idle: every
# request is refused with its reason, and a second client's `status`, sent back to back all
# along, is answered within 100 ms every time (wall clock, less stalls of the whole machine
# that the test process sees itself). The run is exported afterwards and its imu.csv time axis
# has no gap. A library plan given by path is validated and started; a run exported while it
# records has no gap either.
# Usage: blocking_reads.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
LPID=
# Before the daemon is stopped: a daemon stuck opening one of the files (the defect) gets
# unstuck (the lease holder goes, each FIFO sees a writer), so it can take its SIGTERM.
unstick() {
  [[ -n $LPID ]] && kill "$LPID" 2>/dev/null
  local f
  for f in "$W"/*/fifo.toml; do [[ -p $f ]] && : 1<>"$f"; done
  return 0
}
trap 'unstick; e2e_cleanup' EXIT

mkdir "$W/plans" "$W/outside"
cp "$SRC/tests/daemon/data/smoke_plan.toml" "$W/plans/good.toml"
for d in plans outside; do
  mkfifo "$W/$d/fifo.toml"
  echo 'not = "a plan"' >"$W/$d/leased.toml"
  python3 -c '
import sys
line = b"# " + b"x" * 1021 + b"\n"
with open(sys.argv[1], "wb") as f:
    for _ in range(100 * 1024):
        f.write(line)' "$W/$d/big.toml"
done
# The lease holder: opens of the leased files block (or fail with EWOULDBLOCK when O_NONBLOCK).
python3 -c '
import fcntl, os, signal, sys
signal.signal(signal.SIGIO, signal.SIG_IGN)  # the lease-break notice: ignored, never released
fds = []
for p in sys.argv[1:]:
    fd = os.open(p, os.O_RDONLY)
    fcntl.fcntl(fd, getattr(fcntl, "F_SETLEASE", 1024), fcntl.F_WRLCK)
    fds.append(fd)
print("leased", flush=True)
while True:
    signal.pause()' "$W/plans/leased.toml" "$W/outside/leased.toml" >"$W/lease.out" 2>&1 &
LPID=$!
for _ in $(seq 100); do grep -q leased "$W/lease.out" && break; sleep 0.1; done
grep -q leased "$W/lease.out" || fail "lease holder: $(cat "$W/lease.out")"

e2e_bench_file
sed -i "s|^control_socket = .*|&\nplan_dir = \"$W/plans\"|" "$W/bench.toml"
e2e_start_vb --time-scale 2
e2e_start_daemon

e2e_py <<'PY' || fail "blocking read checks"
import socket, statistics, sys, threading, time
from e2e_client import Client, check, read_csv

work = sys.argv[1]
sock = work + "/control.sock"


class StallProbe(threading.Thread):
    """The test's own scheduling: sleeps 5 ms at a time and records how late it woke. When the
    whole machine (the user-mode-linux VM on a loaded host) is descheduled, this sees it too;
    a daemon whose loop blocks does not stall this process."""

    def __init__(self):
        super().__init__(daemon=True)
        self.lags = []  # (woke at, lag s)
        self.running = True

    def run(self):
        while self.running:
            t = time.monotonic()
            time.sleep(0.005)
            now = time.monotonic()
            self.lags.append((now, now - t - 0.005))

    def stalled(self, t0, t1):
        """The longest stall of this process seen between t0 and t1."""
        return max([lag for at, lag in self.lags if t0 <= at <= t1 + 0.05] + [0.0])


class StatusProbe(threading.Thread):
    """Sends status back to back on its own connection; records every round trip (wall)."""

    def __init__(self):
        super().__init__(daemon=True)
        self.c = Client(sock, timeout=30)
        self.trips = []  # (sent at, round trip s)
        self.running = True
        self.stalls = StallProbe()

    def run(self):
        self.stalls.start()
        while self.running or len(self.trips) < 5:  # at least 5, however quick the rest was
            t = time.monotonic()
            r = self.c.reply({"cmd": "status"})
            self.trips.append((t, time.monotonic() - t if r["ok"] else float("inf")))

    def finish(self, what):
        self.running = False
        self.join(35)
        self.stalls.running = False
        self.stalls.join(5)
        check(not self.is_alive(), "status prober ended")
        # A round trip counts less the time the whole machine stood still meanwhile (seen by
        # this process's own sleeps), which is no fault of the daemon's loop.
        worst = max(self.trips, key=lambda p: p[1])
        net = [rtt - self.stalls.stalled(t, t + rtt) for t, rtt in self.trips]
        check(len(self.trips) >= 5 and max(net) < 0.1,
              "%s: %d status round trips, the slowest %.1f ms, %.1f ms less machine stalls "
              "(< 100 ms)" % (what, len(self.trips), 1e3 * worst[1], 1e3 * max(net)))


BAD = [("fifo.toml", "not a regular file"),
       ("leased.toml", "held by another process"),
       ("big.toml", "more than the")]


def bad_requests(c, cmd):
    for d in ("outside", "plans"):
        for name, why in BAD:
            path = "%s/%s/%s" % (work, d, name)
            t = time.monotonic()
            c.sock.settimeout(10)  # a stalled daemon fails the check instead of hanging it
            try:
                r = c.reply({"cmd": cmd, "plan": {"path": path}})
            except socket.timeout:
                raise SystemExit("%s %s/%s: no reply within 10 s (the loop is blocked)"
                                 % (cmd, d, name))
            want = "not in this bench's plan library" if d == "outside" else why
            if d == "plans" and name == "leased.toml" and cmd == "start":
                # The first open started the lease break; after 45 s the kernel ends the
                # lease and the file (not a plan) is read: refused either way, quickly.
                want = path
            check(not r["ok"] and want in r["error"]["message"],
                  "%s %s/%s refused after %.3f s: %s"
                  % (cmd, d, name, time.monotonic() - t, r["error"]["message"][:100]))
            if d == "outside":
                check("send the plan's text" in r["error"]["message"], "the reply says what to do")


def check_no_gap(run, name):
    exp = c.reply({"cmd": "export", "run": run, "dir": name})
    check(exp["ok"], "export: %s" % exp)
    ts = [float(r["t"]) for r in read_csv(exp["result"]["dir"] + "/imu.csv")]
    dts = [b - a for a, b in zip(ts, ts[1:])]
    period = statistics.median(dts)
    check(len(ts) > 2000 and max(dts) < 1.5 * period,
          "run %d: %d IMU samples stored, largest step %.2f ms (period %.2f ms): no gap"
          % (run, len(ts), 1e3 * max(dts), 1e3 * period))


c = Client(sock)
c.subscribe("run")
ok = c.reply({"cmd": "validate_plan", "plan": {"path": work + "/plans/good.toml"}})
check(ok["ok"] and ok["result"]["plan"] == "smoke", "a library plan validates by path: %s" % ok)
listed = c.reply({"cmd": "list_plans"})["result"]["plans"]
check(listed == [work + "/plans/" + n for n in ("big.toml", "good.toml", "leased.toml")],
      "list_plans shows the library's regular files: %s" % listed)
start = c.reply({"cmd": "start", "plan": {"toml": open(work + "/plans/good.toml").read()}})
check(start["ok"], "a plan runs meanwhile")
run = start["result"]["run"]

probe = StatusProbe()
probe.start()
bad_requests(c, "validate_plan")
probe.finish("validate_plan of bad files during a run")
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end")
check(fin["exit"] == "completed", "the run completed")

probe = StatusProbe()
probe.start()
bad_requests(c, "start")
probe.finish("start of bad files")
check(len(c.reply({"cmd": "results"})["result"]["runs"]) == 1, "no run recorded for them")
check_no_gap(run, "run1")

lib = c.reply({"cmd": "start", "plan": {"path": work + "/plans/good.toml"}})
check(lib["ok"] and lib["result"]["plan"] == "smoke", "a library plan starts by path: %s" % lib)
# An export reads a whole run and writes it out: off the loop too, while this run records
# (run 2's IMU time axis is checked after it).
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "r1" and
             e["run"] == lib["result"]["run"], "rotation")
check_no_gap(run, "run1-during-run2")
check(c.reply({"cmd": "abort"})["ok"], "abort it")
c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == lib["result"]["run"], "end")
check_no_gap(lib["result"]["run"], "run2")
PY
if grep "ALARM" "$W/d.out" | grep -qv "abort"; then fail "an alarm in the daemon log"; fi
e2e_stop_daemon
echo "PASS"
