"""A client for imubenchd's control socket, for lab scripts. Python 3 standard library only.

The protocol (daemon/control_protocol.h): newline-delimited JSON over a Unix stream socket.
One request per line, one reply per request, and event lines for the topics a connection
subscribed to. This module mirrors tools/control_client.h:

    from imubench_client import Client
    with Client() as c:                      # $IMUBENCH_SOCKET or /run/imubench/control.sock
        run = c.start("/srv/plans/two_axis_12run.toml", label="unit 42")
        end = c.wait_finished()              # {"state": "finished", "exit": "completed", ...}
        print(c.results(run.get("run")))

Errors are exceptions, all subclasses of ControlError:
    ConnectError       the socket cannot be reached (the message names it)
    ControlTimeout     no reply (or no end of the run) within the timeout
    ConnectionClosed   the daemon closed the connection
    ProtocolError      the daemon sent a line that is not a protocol line (the message quotes it)
    RemoteError        the daemon answered ok=false: .code ("bad_state", "forbidden", ...) and
                       .message ("forbidden": the bench's [control] command_group/read_group
                       does not include this user)

Plans: start(path) and validate_plan(path) read the file here, with the caller's rights, and
send its text (the daemon reads only its own plan library: start(library=...) names one).

Replies' results and events are the typed structs of daemon/control_protocol.h (the daemon
builds them and the C++ CLI reads them with the same code); their fields, as plain dicts here
([..] = may be absent; a newer daemon may add fields, ignore what you do not know):

Replies (the "result" object):
    ping                         {"pong": true}
    subscribe, unsubscribe       {"topics": ["run", "status", ...]}
    start                        {"run", "plan", "steps", "planned_s"}
      with dry_run               {"dry_run": true, "plan", "steps", "planned_s"}
      with queue, when queued    {"queued": {"entry", "position", "plan"}}
    queue_resume                 as start, plus "entry"
    pause, resume, abort         {"run", "state"}
    stop                         {"stopped": true}
    rearm                        {"table": TABLE}
    status                       {"bench", "state", ["imu_time_s"], "imu_lost_samples",
                                  "imu_bad_frames", "imu_restarts", "table": TABLE, ["queued"],
                                  ["run"], ["plan"], ["progress"], ["eta_s"],
                                  ["step": {"index", "label", "kind", "count"}],
                                  ["lab": {"state", "fault", "message", "backlog", "shipped"}]}
                                 state is "idle" or the run's (running, paused, ...)
    list_plans                   {"plan_dir", "plans": [path, ...]}
    validate_plan                {"plan", "steps", "planned_s"}
    results                      {"runs": [{"run", "plan", "state", "exit", "started_unix_s"}]}
    results(run)                 {"run", "state", "exit", "results": [{"kind", "json"}]}
    export                       {"run", "dir", "imu_samples"}
    queue_list, queue_move,      {"queue": [{"entry", "position", "plan", "name", "label",
      queue_remove                           "added_unix_s"}]}
    queue_accept(run)            {"queued": {"entry", "position", "plan"}}
    TABLE = {"interlock": "closed"|"open"|"tripped", "estop", "fault", "state", ["error"],
             ["angles_deg"], ["moving"]}

Events ({"event": name, "topic": topic, ...fields}):
    topic run:     state          {"run", "step", "label", "state", ["exit"]}
                   step_started   {"run", "step", "label"}
                   step_finished  {"run", "step", "label"}
                   alarm          {"run", "step", "label", "message"}
                   imu_restart    {"restarts", "message", ["run"]}
                   run_finished   {"run", "state", "exit"}
                   queued         {"entry", "position", "plan"}
                   queue_started  {"entry", "run", "plan"}
                   queue_held     {"reason"}
                   rearmed        {"run"}
                   step_stats     {"run", "step", "label", "stats"}
                   estimate       {"run", "step", "label", "method", "ok", "parameters":
                                   {name: {"value", "sigma", "unit"}}, "unobservable": [names],
                                   "summary"}
                   results        {"run", "calibrated", "pass", "usable"}
                   resumed        {"run", "from_step"}
                   follow_up      {"run", "status": "proposed"|"refused", "summary", ["plan"],
                                   ["duration_s"], "groups": [{"effects", "resolved", "why"}]}
                   follow_up_verdict {"run", "origin_run", "ok", "summary",
                                   "groups": [{"effects", "verdict"}]}
    topic status:  progress       {"run", "state", "progress", "eta_s", "step", "label"}
step is the 0-based step index; a run has ended when its state is finished (completed unless
"exit" says otherwise), faulted, aborted or interrupted.

Calibration (plans with calibration = "direct" | "indirect" | "pipeline"): the daemon sends
an "estimate" event (topic "run") after each step that allows one -- {"run", "step", "label",
"method", "ok", "parameters": {name: {"value", "sigma", "unit"}}, "unobservable": [names],
"summary"} -- and a "results" event when the end-of-plan calibration is stored ({"run",
"calibrated", "pass": true/false, or null for no verdict (no acceptance limits, or
"usable": false: the fit is unusable), "explain": one-line summary of the missing-physics analysis, or why it
did not run}); calibration(run) returns the stored results by kind ("coefficients",
"report", "verdict", "explain": the imubench-explain/1 report).
"""

import json
import os
import select
import socket
import stat
import time

DEFAULT_SOCKET = "/run/imubench/control.sock"
MAX_LINE_BYTES = 4 * 1024 * 1024
# The daemon's default request size limit (daemon/control_server.h max_line_bytes).
MAX_PLAN_BYTES = 64 * 1024
END_STATES = ("finished", "faulted", "aborted", "interrupted")


def default_socket():
    """$IMUBENCH_SOCKET when set and non-empty, else DEFAULT_SOCKET."""
    return os.environ.get("IMUBENCH_SOCKET") or DEFAULT_SOCKET


class ControlError(Exception):
    """Any failure of the control client."""


class ConnectError(ControlError):
    pass


class ControlTimeout(ControlError):
    pass


class ConnectionClosed(ControlError):
    pass


class ProtocolError(ControlError):
    pass


class RemoteError(ControlError):
    """An ok=false reply: str(e) is "error (code): message"."""

    def __init__(self, code, message):
        super().__init__("error (%s): %s" % (code, message))
        self.code = code
        self.message = message


class RunFailed(ControlError):
    """wait_finished(check=True): the run ended but did not complete. .end is the final state."""

    def __init__(self, end):
        super().__init__("run %s ended %s%s" % (
            end.get("run", "?"), end.get("state", "?"),
            (": " + end["exit"]) if end.get("exit") else ""))
        self.end = end


def _quote(line):
    text = line[:120].decode("utf-8", "backslashreplace") if isinstance(line, bytes) else line[:120]
    out = json.dumps(text)
    if len(line) > 120:
        out += " (%d bytes)" % len(line)
    return out


def read_plan(path):
    """The text of a plan file, read with this process's rights (the daemon reads no files a
    client names, only its own plan library): {"toml": text, "name": absolute path}. Regular
    files only (a FIFO would hang the caller), at most MAX_PLAN_BYTES."""
    path = os.path.abspath(path)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError("%s: not a regular file" % path)
        if st.st_size > MAX_PLAN_BYTES:
            raise ValueError("%s: %d bytes, more than a control request carries (%d)"
                             % (path, st.st_size, MAX_PLAN_BYTES))
        with os.fdopen(fd, "rb", closefd=False) as fh:
            text = fh.read(MAX_PLAN_BYTES + 1)
    finally:
        os.close(fd)
    return {"toml": text.decode("utf-8", "replace"), "name": path}


def _plan_field(path, toml, library):
    given = [x is not None for x in (path, toml, library)]
    if sum(given) != 1:
        raise ValueError("give exactly one of path, toml or library")
    if path is not None:
        return read_plan(path)
    if toml is not None:
        return {"toml": toml}
    return {"path": library}


def run_completed(end):
    """True when a final state (from wait_finished) is a completed run."""
    return end.get("state") == "finished" and end.get("exit", "completed") == "completed"


class Client:
    """A blocking client; one request at a time. Not thread-safe."""

    def __init__(self, path=None, timeout=10.0):
        self.path = path or default_socket()
        self.timeout = timeout
        self._sock = None
        self._buf = b""
        self._eof = False
        self._next_id = 1
        self._events = []
        self._subscribed = set()
        self.connect()

    # ---- connection ----
    def connect(self):
        self.close()
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            s.connect(self.path)
        except OSError as e:
            s.close()
            hint = "is imubenchd running? "
            if isinstance(e, PermissionError):
                hint = "may you use the bench (group imubench)? "
            raise ConnectError("%ssocket %s: %s" % (hint, self.path, e.strerror or e)) from None
        self._sock = s
        self._buf = b""
        self._eof = False
        self._subscribed = set()

    def close(self):
        if self._sock is not None:
            self._sock.close()
        self._sock = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- lines ----
    def _closed(self):
        msg = "imubenchd closed the connection (socket %s)" % self.path
        if self._buf:
            msg += " in the middle of a line: " + _quote(self._buf)
        raise ConnectionClosed(msg)

    def _read_some(self, deadline):
        """Reads into the buffer; False when the deadline (None: none) passed first."""
        if self._sock is None:
            raise ControlError("not connected")
        if self._eof:
            self._closed()
        while True:
            wait = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self._sock], [], [], wait)
            if not ready:
                return False
            try:
                data = self._sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                continue
            except ConnectionResetError:
                data = b""
            if not data:
                self._eof = True
                self._closed()
            self._buf += data
            return True

    def _take_line(self):
        """The next complete line as ("reply"|"event", dict), or None."""
        while True:
            nl = self._buf.find(b"\n")
            if nl < 0:
                if len(self._buf) > MAX_LINE_BYTES:
                    raise ProtocolError("imubenchd sent a line over %d bytes: %s"
                                        % (MAX_LINE_BYTES, _quote(self._buf)))
                return None
            raw, self._buf = self._buf[:nl], self._buf[nl + 1:]
            raw = raw.rstrip(b"\r")
            if not raw.strip():
                continue
            try:
                obj = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, ValueError):
                raise ProtocolError("imubenchd sent a line that is not JSON: " + _quote(raw)) from None
            if isinstance(obj, dict) and isinstance(obj.get("event"), str):
                return "event", obj
            if isinstance(obj, dict) and isinstance(obj.get("ok"), bool):
                if obj["ok"] and isinstance(obj.get("result", {}), dict):
                    return "reply", obj
                if not obj["ok"] and isinstance(obj.get("error"), dict):
                    return "reply", obj
            raise ProtocolError("imubenchd sent a line that is neither a reply nor an event: "
                                + _quote(raw))

    # ---- requests ----
    def request(self, cmd, timeout=None, **fields):
        """Sends {"cmd": cmd, **fields} with an id; returns the reply dict (ok true or false)."""
        if self._sock is None:
            raise ControlError("not connected")
        timeout = self.timeout if timeout is None else timeout
        req = dict(fields)
        req["cmd"] = cmd
        if "id" not in req:
            req["id"] = self._next_id
            self._next_id += 1
        rid = req["id"]
        try:
            self._sock.settimeout(timeout)
            self._sock.sendall((json.dumps(req) + "\n").encode("utf-8"))
        except socket.timeout:
            raise ControlTimeout("imubenchd did not take the request within %g s (socket %s)"
                                 % (timeout, self.path)) from None
        except (BrokenPipeError, ConnectionResetError):
            self._eof = True
            self._closed()
        finally:
            if self._sock is not None:
                self._sock.settimeout(None)
        deadline = None if timeout is None else time.monotonic() + timeout
        for kind, obj in self._incoming(deadline):
            if kind == "event":
                self._events.append(obj)
                continue
            if obj.get("id") == rid:
                return obj
            # An error the daemon could not attach an id to is the answer to our request.
            if obj.get("id") is None and not obj["ok"]:
                return obj
            # else: a late reply to an earlier request that timed out; dropped.
        raise ControlTimeout('no reply from imubenchd to "%s" within %g s (socket %s)'
                             % (cmd, timeout, self.path))

    def _incoming(self, deadline):
        """Yields each line read, as (kind, obj), until none arrives by deadline (None: waits
        forever). Raises ConnectionClosed / ProtocolError."""
        while True:
            got = self._take_line()
            if got is not None:
                yield got
            elif not self._read_some(deadline):
                return

    def call(self, cmd, timeout=None, **fields):
        """request(), then the reply's result; ok=false raises RemoteError."""
        reply = self.request(cmd, timeout=timeout, **fields)
        if reply["ok"]:
            return reply.get("result", {})
        err = reply["error"]
        raise RemoteError(err.get("code", "?"), err.get("message", json.dumps(err)))

    # ---- events ----
    def next_event(self, timeout=None):
        """The next event dict (queued or read within timeout s; None waits forever), or None
        on timeout. Raises ConnectionClosed / ProtocolError."""
        if self._events:
            return self._events.pop(0)
        deadline = None if timeout is None else time.monotonic() + timeout
        for kind, obj in self._incoming(deadline):
            if kind == "event":
                return obj
        return None

    def events(self, timeout=None):
        """Yields events until none arrives within timeout (None: forever)."""
        while True:
            ev = self.next_event(timeout)
            if ev is None:
                return
            yield ev

    def subscribe(self, topics=("run", "status")):
        new = [t for t in topics if t not in self._subscribed]
        if new:
            self.call("subscribe", topics=list(topics))
            self._subscribed.update(topics)

    def unsubscribe(self):
        self.call("unsubscribe")
        self._subscribed = set()

    # ---- commands ----
    def ping(self):
        return self.call("ping")

    def start(self, path=None, toml=None, label=None, dry_run=False, out_dir=None, library=None,
              queue=False):
        """Starts a plan: a file (read here with this process's rights and sent as text, see
        read_plan), the plan's TOML text, or a plan of the daemon's library by the path
        list_plans() reports. Returns the start result (e.g. {"run": 12, ...}). queue=True:
        while a run is going (or plans wait) the plan is validated and appended to the plan
        queue instead; the result is then {"queued": {"entry": 7, "position": 2, "plan": ..}}."""
        plan = _plan_field(path, toml, library)
        options = {}
        if dry_run:
            options["dry_run"] = True
        if queue:
            options["queue"] = True
        if label:
            options["label"] = label
        if out_dir:
            options["out_dir"] = os.path.abspath(out_dir)
        fields = {"plan": plan}
        if options:
            fields["options"] = options
        return self.call("start", **fields)

    def pause(self):
        return self.call("pause")

    def resume(self, run=None):
        """The paused run goes on; with run: that run, interrupted by a daemon crash or stop,
        goes on from its last finished step."""
        if run is None:
            return self.call("resume")
        return self.call("resume", run=run)

    def abort(self):
        return self.call("abort")

    def stop(self):
        """Emergency stop: halt all motion now."""
        return self.call("stop")

    def rearm(self):
        """Close the table's interlock again after a controller restart (then resume)."""
        return self.call("rearm")

    def status(self):
        return self.call("status")

    # ---- the plan queue (stored by the daemon; survives its restart) ----
    def queue_list(self):
        """The queued plans, next first: [{"entry", "position", "plan", "name", "label",
        "added_unix_s"}, ...]."""
        return self.call("queue_list").get("queue", [])

    def queue_move(self, entry, position):
        """Moves queue entry `entry` to `position` (1 = next); returns the queue."""
        return self.call("queue_move", entry=entry, position=position).get("queue", [])

    def queue_remove(self, entry):
        """Takes queue entry `entry` out of the queue; returns the queue."""
        return self.call("queue_remove", entry=entry).get("queue", [])

    def queue_resume(self):
        """Starts the queue's head now (no run going): the start result plus "entry"."""
        return self.call("queue_resume")

    def queue_accept(self, run):
        """Queues the follow-up plan explain proposed at run's end (its "follow_up" result):
        {"queued": {"entry", "position", "plan"}}."""
        return self.call("queue_accept", run=run)

    def results(self, run=None):
        return self.call("results", run=run) if run is not None else self.call("results")

    def calibration(self, run):
        """The calibration results stored for run: {kind: json} (empty while none)."""
        stored = self.results(run).get("results", [])
        return {r["kind"]: r["json"] for r in stored}

    def list_plans(self):
        return self.call("list_plans")

    def validate_plan(self, path=None, toml=None, library=None):
        """Checks a plan without running it; the plan as for start()."""
        return self.call("validate_plan", plan=_plan_field(path, toml, library))

    def wait_finished(self, timeout=None, on_event=None, check=False):
        """Waits until the run ends (state finished, faulted, aborted or interrupted) and
        returns its final state: a dict with "state" and what is known of "exit", "run",
        "plan". Subscribes to run and status events first, then asks the status, so nothing is
        missed between a start() and this call. on_event(event) sees every event. timeout in
        s (None: forever) raises ControlTimeout; check=True raises RunFailed unless the run
        completed."""
        self.subscribe(("run", "status"))
        deadline = None if timeout is None else time.monotonic() + timeout
        end = {}
        st = self.status()
        for key in ("state", "exit", "run", "plan"):
            if key in st:
                end[key] = st[key]
        while end.get("state") not in END_STATES:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            ev = self.next_event(left)
            if ev is None:
                raise ControlTimeout("the run did not end within %g s (state %s)"
                                     % (timeout, end.get("state", "?")))
            if on_event is not None:
                on_event(ev)
            if ev.get("event") in ("state", "status", "progress"):
                for key in ("state", "exit", "run", "plan"):
                    if key in ev:
                        end[key] = ev[key]
        if check and not run_completed(end):
            raise RunFailed(end)
        return end
