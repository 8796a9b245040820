#!/usr/bin/env python3
"""tools/python/imubench_client.py and examples/thermal_sweep.py against a fake imubenchd: a
small NDJSON server (socketserver over AF_UNIX, one thread per connection) in a mkdtemp
directory. Fails (never skips) when anything is wrong. Run: python3 test_python_client.py"""

import json
import os
import shutil
import socket
import socketserver
import subprocess
import sys
import tempfile
import threading
import unittest

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
PY = os.path.join(ROOT, "tools", "python")
sys.path.insert(0, PY)
sys.path.insert(0, os.path.join(PY, "examples"))
import imubench_client as ic  # noqa: E402
import thermal_sweep  # noqa: E402


class FakeDaemon(socketserver.ThreadingUnixStreamServer):
    """start -> a run; the first status of a running run is answered, then the run's events are
    broadcast to subscribers up to finished (exit "aborted" for labels in abort_labels)."""
    daemon_threads = True

    def __init__(self, path, abort_labels=()):
        super().__init__(path, Handler)
        self.lock = threading.Lock()
        self.subscribers = []
        self.state = "idle"
        self.run = 0
        self.label = ""
        self.played = True
        self.abort_labels = abort_labels
        self.starts = []  # (label, plan) of every start

    def broadcast(self, events):
        with self.lock:
            for w in list(self.subscribers):
                try:
                    for ev in events:
                        w.write((json.dumps(ev) + "\n").encode())
                    w.flush()
                except OSError:
                    self.subscribers.remove(w)


class Handler(socketserver.StreamRequestHandler):
    def reply(self, rid, result=None, error=None):
        msg = {"id": rid, "ok": error is None}
        if error is None:
            msg["result"] = result or {}
        else:
            msg["error"] = {"code": error[0], "message": error[1]}
        with self.server.lock:
            self.wfile.write((json.dumps(msg) + "\n").encode())
            self.wfile.flush()

    def handle(self):
        srv = self.server
        for raw in self.rfile:
            req = json.loads(raw)
            rid, cmd = req.get("id"), req.get("cmd")
            if cmd == "ping":
                self.reply(rid, {"pong": True})
            elif cmd == "subscribe":
                with srv.lock:
                    srv.subscribers.append(self.wfile)
                self.reply(rid, {"topics": req["topics"]})
            elif cmd == "start":
                if srv.state == "running":
                    self.reply(rid, error=("busy", "a run is going"))
                    continue
                srv.run += 1
                srv.label = req.get("options", {}).get("label", "")
                srv.starts.append((srv.label, req["plan"]))
                srv.state = "running"
                srv.played = False
                self.reply(rid, {"run": srv.run, "plan": "thermal_point"})
            elif cmd == "status":
                st = {"state": srv.state, "run": srv.run}
                if srv.state == "running":
                    st["step"] = {"index": 0, "count": 2, "label": "soak"}
                self.reply(rid, st)
                if srv.state == "running" and not srv.played:
                    srv.played = True
                    srv.state = "finished"
                    exit_ = "aborted" if srv.label in srv.abort_labels else "completed"
                    srv.broadcast([
                        {"event": "state", "topic": "run", "state": "running"},
                        {"event": "step_started", "topic": "run", "step": 0, "label": "soak"},
                        {"event": "progress", "topic": "status", "progress": 0.5, "eta_s": 60},
                        {"event": "alarm", "topic": "run", "message": "chamber overshoot"},
                        {"event": "step_started", "topic": "run", "step": 1, "label": "outer"},
                        {"event": "state", "topic": "run", "state": "finished", "exit": exit_},
                    ])
            elif cmd == "pause":
                self.reply(rid, error=("bad_state", "not running (state %s)" % srv.state))
            elif cmd == "results":
                if req.get("run", srv.run) != srv.run:
                    self.reply(rid, error=("not_found", "no run %s" % req["run"]))
                else:
                    self.reply(rid, {"run": srv.run, "label": srv.label, "gyro.bias.x": 1.5e-5})
            elif cmd == "garbage":
                self.wfile.write(b"\x00\xffnot json\n")
            elif cmd == "array":
                self.wfile.write(b"[1, 2]\n")
            elif cmd == "hangup":
                self.wfile.write(b'{"id":')
                return
            elif cmd == "silent":
                pass
            elif cmd == "late":  # a stale reply, an unrelated id, then the real one
                self.wfile.write(b'{"id":-5,"ok":true,"result":{}}\n')
                self.reply(rid, {"late": True})
            else:
                self.reply(rid, error=("unknown_command", "cmd: unknown command %s" % cmd))


class ClientTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="imubench-pyclient-")
        self.path = os.path.join(self.dir, "control.sock")
        self.server = FakeDaemon(self.path, abort_labels=("T=+60C",))
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def tearDown(self):
        self.server.shutdown()
        self.server.server_close()
        self.thread.join(10)
        shutil.rmtree(self.dir, ignore_errors=True)

    def test_missing_socket_names_it(self):
        missing = os.path.join(self.dir, "nobody.sock")
        with self.assertRaises(ic.ConnectError) as cm:
            ic.Client(missing)
        self.assertEqual(str(cm.exception),
                         "is imubenchd running? socket %s: No such file or directory" % missing)

    def test_env_overrides_default_socket(self):
        old = os.environ.get("IMUBENCH_SOCKET")
        try:
            os.environ["IMUBENCH_SOCKET"] = self.path
            with ic.Client() as c:
                self.assertEqual(c.path, self.path)
                self.assertEqual(c.ping(), {"pong": True})
            del os.environ["IMUBENCH_SOCKET"]
            self.assertEqual(ic.default_socket(), "/run/imubench/control.sock")
        finally:
            if old is not None:
                os.environ["IMUBENCH_SOCKET"] = old

    def test_round_trip_ids_and_errors(self):
        with ic.Client(self.path) as c:
            self.assertEqual(c.request("ping"), {"id": 1, "ok": True, "result": {"pong": True}})
            self.assertEqual(c.request("status")["id"], 2)
            self.assertEqual(c.request("ping", id="mine")["id"], "mine")
            reply = c.request("pause")
            self.assertFalse(reply["ok"])
            with self.assertRaises(ic.RemoteError) as cm:
                c.pause()
            self.assertEqual(cm.exception.code, "bad_state")
            self.assertEqual(str(cm.exception), "error (bad_state): not running (state idle)")
            self.assertEqual(c.call("late"), {"late": True})  # the stray reply was dropped
            with self.assertRaises(ValueError):
                c.start()

    def test_start_wait_finished_and_results(self):
        seen = []
        with ic.Client(self.path) as c:
            c.subscribe()
            # Issue 17: the client reads the plan (with its own rights) and sends the text,
            # named by the file's absolute path; it used to send the path for the daemon.
            plan_file = os.path.join(self.dir, "plan.toml")
            with open(plan_file, "w") as fh:
                fh.write("[plan]\nname = \"p\"\n")
            rel = os.path.relpath(plan_file)
            started = c.start(rel, label="unit 42", dry_run=False)
            self.assertEqual(started["run"], 1)
            self.assertEqual(self.server.starts[0][1],
                             {"toml": "[plan]\nname = \"p\"\n", "name": plan_file})
            end = c.wait_finished(timeout=10, on_event=seen.append, check=True)
            self.assertEqual(end, {"state": "finished", "exit": "completed", "run": 1})
            self.assertTrue(ic.run_completed(end))
            self.assertIn({"event": "alarm", "topic": "run", "message": "chamber overshoot"},
                          seen)
            self.assertEqual(c.results(1)["label"], "unit 42")
            with self.assertRaises(ic.RemoteError) as cm:
                c.results(99)
            self.assertEqual(cm.exception.code, "not_found")
            # Nothing more comes: next_event times out with None, promptly.
            self.assertIsNone(c.next_event(0.05))

    def test_events_between_replies_are_queued(self):
        with ic.Client(self.path) as c:
            c.subscribe(["run", "status"])
            c.start(toml="[plan]\n")
            self.assertEqual(c.status()["state"], "running")
            self.assertEqual(c.ping(), {"pong": True})  # the events came before this reply
            events = list(c.events(timeout=0))
            self.assertEqual([e["event"] for e in events],
                             ["state", "step_started", "progress", "alarm", "step_started",
                              "state"])

    def test_failed_run_raises_with_check(self):
        with ic.Client(self.path) as c:
            c.subscribe()
            c.start(toml="x", label="T=+60C")
            with self.assertRaises(ic.RunFailed) as cm:
                c.wait_finished(timeout=10, check=True)
            self.assertEqual(cm.exception.end["exit"], "aborted")
            self.assertFalse(ic.run_completed(cm.exception.end))

    def test_garbage_and_closed_connection_are_errors(self):
        with ic.Client(self.path) as c:
            with self.assertRaises(ic.ProtocolError) as cm:
                c.request("garbage")
            self.assertIn("not JSON", str(cm.exception))
            self.assertIn("not json", str(cm.exception))
        with ic.Client(self.path) as c:
            with self.assertRaises(ic.ProtocolError) as cm:
                c.request("array")
            self.assertIn('neither a reply nor an event: "[1, 2]"', str(cm.exception))
        with ic.Client(self.path) as c:
            with self.assertRaises(ic.ConnectionClosed) as cm:
                c.request("hangup")
            self.assertIn('closed the connection (socket %s) in the middle of a line: "{\\"id\\":"'
                          % self.path, str(cm.exception))
            with self.assertRaises(ic.ConnectionClosed):
                c.next_event(1)
        with ic.Client(self.path, timeout=0.2) as c:
            with self.assertRaises(ic.ControlTimeout) as cm:
                c.request("silent")
            self.assertIn('no reply from imubenchd to "silent" within 0.2 s', str(cm.exception))

    def test_plan_template_substitution(self):
        with open(os.path.join(PY, "examples", "thermal_point.toml"), encoding="utf-8") as f:
            template = f.read()
        plan = thermal_sweep.plan_at(template, -20)
        self.assertIn('setpoint = "-20 degC"', plan)
        self.assertNotIn('setpoint = "20 degC"', plan)
        self.assertEqual(len(plan.splitlines()), len(template.splitlines()))
        with self.assertRaises(ValueError):
            thermal_sweep.plan_at("[plan]\n", 20)
        self.assertEqual(thermal_sweep.label_for(20), "T=+20C")
        self.assertEqual(thermal_sweep.label_for(-20), "T=-20C")

    def sweep(self, temps):
        script = os.path.join(PY, "examples", "thermal_sweep.py")
        return subprocess.run([sys.executable, script, "--socket", self.path, "--temps=" + temps],
                              capture_output=True, text=True, timeout=60)

    def test_thermal_sweep_runs_each_temperature(self):
        p = self.sweep("-20,20")
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("T=-20C: started run 1\n", p.stdout)
        self.assertIn("T=-20C: run 1 completed\n", p.stdout)
        self.assertIn("T=+20C: run 2 completed\n", p.stdout)
        self.assertIn("  ALARM: chamber overshoot\n", p.stdout)
        self.assertIn('"label": "T=+20C"', p.stdout)
        labels = [label for label, _ in self.server.starts]
        self.assertEqual(labels, ["T=-20C", "T=+20C"])
        self.assertIn('setpoint = "-20 degC"', self.server.starts[0][1]["toml"])
        self.assertIn('setpoint = "20 degC"', self.server.starts[1][1]["toml"])

    def test_thermal_sweep_stops_at_a_failed_run(self):
        p = self.sweep("20,60,-20")
        self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
        self.assertIn("T=+60C: run 2 ended finished aborted; sweep stopped", p.stderr)
        self.assertEqual([label for label, _ in self.server.starts], ["T=+20C", "T=+60C"])

    def test_plans_are_read_here_library_plans_by_path(self):
        fifo = os.path.join(self.dir, "plan.fifo")
        os.mkfifo(fifo)
        with ic.Client(self.path) as c:
            with self.assertRaises(ValueError) as cm:
                c.start(fifo)  # a FIFO would hang a blocking read; refused at once
            self.assertIn("not a regular file", str(cm.exception))
            big = os.path.join(self.dir, "big.toml")
            with open(big, "w") as fh:
                fh.write("#" * (ic.MAX_PLAN_BYTES + 1))
            with self.assertRaises(ValueError):
                c.validate_plan(big)
            with self.assertRaises(FileNotFoundError):
                c.start(os.path.join(self.dir, "none.toml"))
            with self.assertRaises(ValueError):
                c.start(toml="x", library="/p.toml")
            c.start(library="/etc/imubench/plans/p.toml")
            self.assertEqual(self.server.starts[-1][1], {"path": "/etc/imubench/plans/p.toml"})


class NoServerTest(unittest.TestCase):
    def test_thermal_sweep_without_daemon(self):
        d = tempfile.mkdtemp(prefix="imubench-pyclient-")
        try:
            sock = os.path.join(d, "none.sock")
            p = subprocess.run([sys.executable, os.path.join(PY, "examples", "thermal_sweep.py"),
                                "--socket", sock], capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 1)
            self.assertIn("is imubenchd running? socket %s" % sock, p.stderr)
        finally:
            shutil.rmtree(d, ignore_errors=True)

    def test_socket_path_too_long(self):
        with self.assertRaises(ic.ConnectError):
            ic.Client("/tmp/" + "x" * 200)


if __name__ == "__main__":
    unittest.main(verbosity=2)
