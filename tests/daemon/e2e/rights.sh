#!/usr/bin/env bash
# Issue 15: command rights by the peer's credentials (SO_PEERCRED), through the real imubenchd.
# The bench file names a command group (daemon, gid 1) and a read group (nogroup, gid 65534);
# the test runs as root (allowed everything) and as two other users via setpriv:
#   - nobody (uid 65534, primary gid 65534 = the read group, no other groups) is refused start,
#     abort and the queue's changes (error "forbidden" naming the command, its uid and the
#     group), may status, results and watch, and its emergency stop ends root's running plan
#     "faulted" (emergency_stop);
#   - uid 12345 (in no configured group) may only stop and ping;
#   - an unknown group in the bench file stops the daemon at start with file:line.
# Usage: rights.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
# The scratch directory under /tmp, not under vcan-run's private (0700) TMPDIR: other users
# must reach the socket in it.
TMPDIR=/tmp e2e_init "$@"
[[ $(id -u) == 0 ]] || fail "needs root (runs inside user-mode-linux as root) to switch users"

chmod 0755 "$W"  # other users reach the socket (its directory) ...
e2e_bench_file '[control]
command_group = "daemon"
read_group = "nogroup"'
e2e_start_vb --time-scale 2
e2e_start_daemon
chmod 0666 "$W/control.sock"  # ... and the socket itself (SocketMode=0666 under systemd)
grep -q "control rights: commands need group daemon, reading needs group nogroup" "$W/d.out" ||
  fail "the daemon does not log its rights"

as_nobody=(setpriv --reuid=65534 --regid=65534 --clear-groups)
# The smoke plan with 300 s holds: the run must still be running when the other users try (the
# 5 s holds ended it first under load: "nobody may status" saw the bench idle); nobody's
# emergency stop ends it.
sed 's/^duration = "5 s"/duration = "300 s"/' "$SRC/tests/daemon/data/smoke_plan.toml" >"$W/smoke.toml"
grep -q '^duration = "300 s"' "$W/smoke.toml" || fail "smoke plan copy"
chmod 0644 "$W/smoke.toml"

# Root starts a plan; it runs while the others try.
e2e_py <<'PY' || fail "root starts"
import sys
from e2e_client import Client, check, plan_file
c = Client(sys.argv[1] + "/control.sock")
r = c.reply({"cmd": "start", "plan": plan_file(sys.argv[1] + "/smoke.toml")})
check(r["ok"], "root may start: %s" % r)
PY

# The Python parts drop to the other user themselves (python3 may live under /root, which
# other users cannot read): every module is imported before.
e2e_py 65534 <<'PY' || fail "nobody"
import os, sys
from e2e_client import Client, check, plan_file
work = sys.argv[1]
os.setgroups([]); os.setgid(int(sys.argv[2])); os.setuid(int(sys.argv[2]))
check(os.getuid() == 65534 and os.getgroups() in ([], [65534]), "running as nobody")
c = Client(work + "/control.sock")
c.subscribe("run")
st = c.reply({"cmd": "status"})
check(st["ok"] and st["result"]["state"] == "running", "nobody may status: %s" % st["result"])
run = st["result"]["run"]
check(c.reply({"cmd": "results"})["ok"], "nobody may read the results")
for req in ({"cmd": "start", "plan": plan_file(work + "/smoke.toml")}, {"cmd": "abort"},
            {"cmd": "pause"}):
    r = c.reply(req)
    msg = r.get("error", {}).get("message", "")
    check(not r["ok"] and r["error"]["code"] == "forbidden" and
          msg.startswith(req["cmd"] + ": forbidden for uid 65534") and "group daemon (gid 1)" in msg,
          "nobody is refused %s: %s" % (req["cmd"], msg))
check(c.reply({"cmd": "status"})["result"]["state"] == "running", "the run goes on")
r = c.reply({"cmd": "stop"})
check(r["ok"] and r["result"]["stopped"], "nobody may send the emergency stop")
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end", 60)
check(fin["state"] == "faulted" and fin["exit"] == "emergency_stop",
      "nobody's stop ends the run faulted: %s" % fin)
PY

# The CLI as nobody: refused start (exit 1, the error), status works.
if "${as_nobody[@]}" "$CLI" start "$W/smoke.toml" >"$W/cli.out" 2>&1; then
  fail "the CLI as nobody started a plan"
fi
grep -q "error (forbidden): start: forbidden for uid 65534" "$W/cli.out" || fail "CLI: $(cat "$W/cli.out")"
"${as_nobody[@]}" "$CLI" status >"$W/cli.out" 2>&1 || fail "CLI status as nobody: $(cat "$W/cli.out")"
echo "ok: the CLI as nobody: start refused, status works"

e2e_py 12345 <<'PY' || fail "stranger"
import os, sys
from e2e_client import Client, check
os.setgroups([]); os.setgid(int(sys.argv[2])); os.setuid(int(sys.argv[2]))
c = Client(sys.argv[1] + "/control.sock")
for cmd in ("status", "results", "list_plans"):
    r = c.reply({"cmd": cmd})
    check(not r["ok"] and r["error"]["code"] == "forbidden" and
          "uid 12345" in r["error"]["message"] and "nogroup (gid 65534)" in r["error"]["message"],
          "a user in no group is refused %s: %s" % (cmd, r["error"]["message"]))
check(c.reply({"cmd": "ping"})["ok"], "a user in no group may ping")
check(c.reply({"cmd": "stop"})["ok"], "a user in no group may send the emergency stop")
PY
grep -q "client [0-9]*: status: forbidden for uid 12345" "$W/d.out" || fail "refusal not logged"
e2e_stop_daemon

# An unknown group refuses the bench file at start, naming file and line.
e2e_bench_file '[control]
command_group = "no-such-group-imubench"'
if "$DAEMON" --bench "$W/bench.toml" --stderr >"$W/d2.out" 2>&1; then
  fail "the daemon started with an unknown group"
fi
grep -q "bench.toml:[0-9]*:[0-9]*: command_group: no group \"no-such-group-imubench\"" "$W/d2.out" ||
  fail "unknown group: $(cat "$W/d2.out")"
echo "ok: an unknown group is refused at load: $(grep -m1 no-such-group "$W/d2.out")"
echo "PASS"
