#!/usr/bin/env bash
# Issue 28 item 1: no line a client sends kills imubenchd. Runs under tools/vcan-run.sh
# (virtual bench + imubenchd). While a plan records:
#   1. the 26-byte line `{"cmd":"ping","id":1e400}` (it aborted the daemon: nlohmann's
#      out_of_range.406 escaped the parser) gets a bad_json reply, from root and from nobody;
#   2. a generated corpus of 10,000 lines (fixed seed: mutations of valid read requests, random
#      bytes, deep nesting, numbers out of range, odd types in every field, huge strings, NUL
#      bytes, invalid UTF-8, over-long lines) over four connections: every line is answered
#      (a reply per line, checked with a ping marker after each batch), the connections stay;
# then the daemon is still running, answers `imubench status`, the run is still running (no
# line stopped it), and the run's exported IMU time axis has no gap.
# Usage: hostile_lines.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
# Under /tmp (not vcan-run's private TMPDIR): nobody must reach the socket.
TMPDIR=/tmp e2e_init "$@"
[[ $(id -u) == 0 ]] || fail "needs root (runs inside user-mode-linux as root) to switch users"
chmod 0755 "$W"

{
  e2e_plan_head long-hold "a quiet run recorded while the socket is fuzzed"
  e2e_hold h1 "600 s"
} >"$W/plan.toml"
e2e_bench_file "$E2E_SLOW_IMU"
e2e_start 1
chmod 0666 "$W/control.sock"

e2e_py "$W/plan.toml" <<'PY' || fail "start"
import sys
from e2e_client import start_run
c = start_run(sys.argv[1], sys.argv[2])
c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == "h1", "hold")
PY

# 1. The line, as root and as nobody (uid 65534: it came before any rights check).
for who in 0 65534; do
  e2e_py "$who" <<'PY' || fail "the 1e400 line (uid $who)"
import os, socket, sys
from e2e_client import check
uid = int(sys.argv[2])
if uid:
    os.setgroups([]); os.setgid(uid); os.setuid(uid)
s = socket.socket(socket.AF_UNIX)
s.settimeout(10)
s.connect(sys.argv[1] + "/control.sock")
s.sendall(b'{"cmd":"ping","id":1e400}\n')
reply = s.makefile("rb").readline()
check(b'"code":"bad_json"' in reply and b"1e400" in reply,
      "uid %d: the 1e400 line is answered bad_json: %r" % (uid, reply))
s.sendall(b'{"cmd":"ping","id":2}\n')
check(b'"pong":true' in s.makefile("rb").readline(), "uid %d: the connection goes on" % uid)
PY
done
kill -0 "$DPID" || fail "imubenchd died on the 1e400 line"

# 2. The corpus.
e2e_py <<'PY' || fail "fuzz corpus"
import json, random, socket, sys
from e2e_client import check

rng = random.Random(0x1E400)
# Read requests only: a mutation must not become a command that changes the run.
VALID = [b'{"id":1,"cmd":"status"}', b'{"cmd":"results","run":1}', b'{"cmd":"ping","id":"p"}',
         b'{"id":2,"cmd":"queue_list"}', b'{"cmd":"list_plans"}',
         b'{"cmd":"validate_plan","plan":{"toml":"[plan]\\nname = \\"x\\""}}',
         b'{"cmd":"subscribe","topics":["log"]}']
NUMBERS = [b"1e400", b"-1e400", b"1E+99999", b"9" * 400, b"1e-400", b"18446744073709551616",
           b"-9223372036854775809", b"1.7976931348623157e308", b"-0"]
ODD = NUMBERS + [b"null", b"true", b"[]", b"{}", b'"x"', b'"\\u0000"', b'"\\ud800"',
                 b'"\xff\xfe"', b'"' + b"y" * 20000 + b'"', b"[" * 40 + b"]" * 40]
SAFE_COMMANDS = {"status", "results", "ping", "queue_list", "list_plans", "validate_plan",
                 "subscribe", "unsubscribe"}
CHANGING = {"start", "stop", "pause", "resume", "abort", "rearm", "export", "queue_move",
            "queue_remove", "queue_resume"}


def line_for(i):
    kind = i % 7
    base = bytearray(rng.choice(VALID))
    if kind == 0:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300)))
    if kind == 1:
        for _ in range(rng.randrange(1, 6)):
            base[rng.randrange(len(base))] = rng.randrange(256)
        return bytes(base)
    if kind == 2:
        at = [k for k, ch in enumerate(base) if ch == ord(":")]
        k = rng.choice(at)
        end = min([j for j in range(k + 1, len(base)) if base[j] in b",}"] or [len(base)])
        return bytes(base[:k + 1]) + rng.choice(ODD) + bytes(base[end:])
    if kind == 3:
        depth = rng.randrange(33, 5000)
        deep = rng.choice([b"[", b"{"]) * depth
        return deep if rng.random() < 0.5 else b'{"cmd":"status","id":' + deep + b"}"
    if kind == 4:
        return b'{"cmd":"ping","id":' + rng.choice(NUMBERS) + b"}"
    if kind == 5:
        return b'{"cmd":"' + bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40))) + b'"}'
    return b'{"cmd":"results","run":' + rng.choice(ODD) + b"}"


def harmless(line):
    """False for a line that reads as a command changing the run (a mutation could make one)."""
    try:
        doc = json.loads(line)
    except Exception:
        return True
    return not isinstance(doc, dict) or not isinstance(doc.get("cmd"), str) or \
        doc["cmd"] in SAFE_COMMANDS or doc["cmd"] not in CHANGING


corpus = []
while len(corpus) < 10000:
    line = line_for(len(corpus)).replace(b"\n", b" ").replace(b"\r", b" ")
    if harmless(line):
        corpus.append(line)
corpus[5] = b"x" * (70 * 1024)  # over max_line_bytes: too_large, the rest of it discarded
check(sum(len(l) for l in corpus) > 10**6, "corpus of %d lines, %d bytes"
      % (len(corpus), sum(len(l) for l in corpus)))

conns = []
for _ in range(4):
    s = socket.socket(socket.AF_UNIX)
    s.settimeout(20)
    s.connect(sys.argv[1] + "/control.sock")
    conns.append((s, s.makefile("rb")))
answered = 0
BATCH = 50
for b in range(0, len(corpus), BATCH):
    s, f = conns[(b // BATCH) % len(conns)]
    lines = corpus[b:b + BATCH]
    marker = "m%d" % b
    s.sendall(b"\n".join(lines) + b'\n{"cmd":"ping","id":"' + marker.encode() + b'"}\n')
    # One reply per line that is not blank, then the marker's pong.
    want = sum(1 for l in lines if l.strip(b" \t"))
    got = 0
    while True:
        raw = f.readline()
        if not raw.endswith(b"\n"):
            raise SystemExit("batch %d: the daemon closed the connection" % b)
        reply = json.loads(raw)
        if "event" in reply:
            continue
        if reply.get("id") == marker:
            break
        got += 1
    if got != want:
        raise SystemExit("batch %d: %d replies to %d lines" % (b, got, want))
    answered += got
check(answered > 9900, "%d of the corpus lines answered, every connection kept" % answered)
PY
kill -0 "$DPID" || fail "imubenchd died on the corpus"
"$CLI" status | tee "$W/status.out" || fail "imubench status after the corpus"
grep -q "^state: running" "$W/status.out" || fail "the run is not running any more"

e2e_py <<'PY' || fail "no gap"
import statistics, sys
from e2e_client import Client, check, read_csv
c = Client(sys.argv[1] + "/control.sock")
c.subscribe("run")
run = c.reply({"cmd": "status"})["result"]["run"]
check(c.reply({"cmd": "abort"})["ok"], "abort the run")
c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end")
exp = c.reply({"cmd": "export", "run": run, "dir": "fuzzed"})
check(exp["ok"], "export: %s" % exp)
ts = [float(r["t"]) for r in read_csv(exp["result"]["dir"] + "/imu.csv")]
dts = [b - a for a, b in zip(ts, ts[1:])]
period = statistics.median(dts)
check(len(ts) > 2000 and max(dts) < 1.5 * period,
      "%d IMU samples stored while fuzzed, largest step %.2f ms (period %.2f ms): no gap"
      % (len(ts), 1e3 * max(dts), 1e3 * period))
PY
e2e_stop_daemon
echo "PASS"
