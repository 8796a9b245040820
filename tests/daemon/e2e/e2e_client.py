"""Control-socket client of the daemon's end-to-end tests (stdlib only).

    from e2e_client import Client, check, plan_file
    c = Client(work + "/control.sock")
    c.reply({"cmd": "start", "plan": plan_file(path)})
    c = start_run(work, path)                  # subscribed to "run", the plan started: c.run
    c.reply({"cmd": "status"})                 # ids assigned; events seen meanwhile are queued
    c.wait_event(lambda e: e["event"] == "run_finished", "run end", limit=120)
"""
import json
import socket
import time


def check(cond, what):
    if not cond:
        raise SystemExit("check failed: " + what)
    print("ok:", what, flush=True)


class Client:
    def __init__(self, path, timeout=150.0):
        self.sock = socket.socket(socket.AF_UNIX)
        self.sock.connect(path)
        self.sock.settimeout(timeout)
        # Read-only: a text file object opened "rw" drops the lines it has read ahead whenever
        # it is written to (CPython's TextIOWrapper.write resets its decoder), which lost events
        # that arrived with a reply; requests go out through sendall.
        self.f = self.sock.makefile("r", encoding="utf-8")
        self.events = []
        self.next_id = 1

    def close(self):
        self.f.close()
        self.sock.close()

    def send(self, obj):
        line = (obj if isinstance(obj, str) else json.dumps(obj)) + "\n"
        self.sock.sendall(line.encode("utf-8"))

    def reply(self, obj):
        if isinstance(obj, dict) and "id" not in obj:
            obj = dict(obj, id=self.next_id)
            self.next_id += 1
        self.send(obj)
        while True:
            line = json.loads(self.f.readline())
            if "event" in line:
                self.events.append(line)
            else:
                return line

    def subscribe(self, *topics):
        r = self.reply({"cmd": "subscribe", "topics": list(topics)})
        check(r["ok"], "subscribe %s" % (topics,))

    def wait_event(self, pred, what, limit=120.0):
        for e in self.events:
            if pred(e):
                self.events.remove(e)
                return e
        end = time.time() + limit
        self.sock.settimeout(limit)
        try:
            while time.time() < end:
                line = self.f.readline()
                if not line:
                    break
                e = json.loads(line)
                if "event" not in e:
                    continue
                if pred(e):
                    return e
                self.events.append(e)
        except socket.timeout:
            pass
        raise SystemExit("timed out waiting for %s; events: %s" % (what, self.events[-10:]))


def plan_file(path):
    """A plan file sent as its text, named by its path, as `imubench start` does (the daemon
    reads by path only its own plan library)."""
    with open(path) as fh:
        return {"toml": fh.read(), "name": path}


def start_run(work, plan):
    """A client of the daemon in `work`, subscribed to "run", that started the plan file `plan`
    (checked); the run's id in c.run."""
    c = Client(work + "/control.sock")
    c.subscribe("run")
    start = c.reply({"cmd": "start", "plan": plan_file(plan)})
    check(start["ok"], "start: %s" % start)
    c.run = start["result"]["run"]
    return c


def read_csv(path):
    import csv
    with open(path) as fh:
        return list(csv.DictReader(l for l in fh if not l.startswith("#")))
