#!/usr/bin/env bash
# Issue 17, defect 9: what a client of the control socket may make the daemon read and write.
# Runs under tools/vcan-run.sh (virtual bench + imubenchd), umask 022 like a default shell.
#   - The database and its -wal/-shm are 0640 (a new one, and an existing 0644 one tightened).
#   - export writes only under exports/ next to the database: an absolute path or a path with
#     a slash is refused (and nothing appears there), a name lands under exports/, an existing
#     export is not overwritten.
#   - Plans are read with the client's rights: a path outside the plan library is refused
#     without being read, and the reply echoes nothing of a file the client could not read;
#     the imubench CLI and the Python client read the plan themselves and send its text; run
#     as another user, the CLI cannot read a file that user may not read.
# Usage: access.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
umask 022

mode_of() { stat -c %a "$1"; }

mkdir "$W/plans" "$W/private"
cp "$SRC/tests/daemon/data/smoke_plan.toml" "$W/plans/smoke.toml"
cp "$SRC/tests/daemon/data/smoke_plan.toml" "$W/private/mine.toml"
printf '[plan]\nname = "x"\nsecret_api_token_key = 1\n[wifi_password_section]\n' \
  >"$W/private/root-only.toml"
chmod 0600 "$W/private/root-only.toml"

e2e_bench_file
sed -i "s|^control_socket = .*|&\nplan_dir = \"$W/plans\"|" "$W/bench.toml"
e2e_start_vb --time-scale 5
e2e_start_daemon
[[ $(mode_of "$W/imubench.db") == 640 ]] || fail "new database mode $(mode_of "$W/imubench.db")"
echo "ok: a new database is 0640"

PYTHONPATH="$SRC/tools/python" e2e_py <<'PY' || fail "access checks"
import json, os, sys
from e2e_client import Client, check
import imubench_client

work = sys.argv[1]
c = Client(work + "/control.sock")
c.subscribe("run")

# Plans: a path outside the library is refused untouched and echoes nothing of the file.
secret = work + "/private/root-only.toml"
for cmd in ("validate_plan", "start"):
    r = c.reply({"cmd": cmd, "plan": {"path": secret}})
    msg = r.get("error", {}).get("message", "")
    check(not r["ok"] and r["error"]["code"] == "bad_argument" and "send the plan's text" in msg,
          "%s of a path outside the plan library refused: %s" % (cmd, msg))
    check("secret_api_token_key" not in json.dumps(r) and "wifi_password" not in json.dumps(r),
          "%s: the reply echoes nothing of the file" % cmd)
check(len(c.reply({"cmd": "results"})["result"]["runs"]) == 0, "no run was started")

# The Python client reads the file itself (with its rights) and sends the text by name.
with imubench_client.Client(work + "/control.sock") as py:
    v = py.validate_plan(work + "/private/mine.toml")
    check(v["plan"] == "smoke", "the Python client validates a plan outside the library")
    try:
        py.validate_plan(toml="[plan]\nname = 3\n")
        check(False, "a bad inline plan is refused")
    except imubench_client.RemoteError as e:
        check(e.code == "bad_plan" and "inline plan" in e.message, "inline diagnostics: " + e.message)
    bad = open(work + "/private/mine.toml").read().replace('"two-axis"', '"five-axis"')
    r = c.reply({"cmd": "validate_plan", "plan": {"toml": bad, "name": "/home/op/mine.toml"}})
    check(not r["ok"] and r["error"]["message"].startswith("/home/op/mine.toml:"),
          "diagnostics name the client's file: " + r["error"]["message"][:80])
    run = py.start(work + "/private/mine.toml")["run"]
end = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end")
check(end["exit"] == "completed", "the plan sent as text ran")

# Export: only under exports/ next to the database.
for bad in ("/tmp/imubench-e2e-export", work + "/private/x", "../x", "a/b", ".hidden"):
    r = c.reply({"cmd": "export", "run": run, "dir": bad})
    check(not r["ok"] and r["error"]["code"] == "bad_argument", "export to %r refused" % bad)
check(not os.path.exists("/tmp/imubench-e2e-export") and not os.path.exists(work + "/private/x")
      and not os.path.exists(work + "/x"), "nothing written outside")
r = c.reply({"cmd": "export", "run": run, "dir": "unit42"})
check(r["ok"] and r["result"]["dir"] == work + "/exports/unit42" and
      os.path.getsize(work + "/exports/unit42/imu.csv") > 0, "export under exports/: %s" % r)
r = c.reply({"cmd": "export", "run": run})
check(r["ok"] and r["result"]["dir"] == work + "/exports/run-%d" % run, "default export name")
r = c.reply({"cmd": "export", "run": run, "dir": "unit42"})
check(not r["ok"] and "exists already" in r["error"]["message"], "an export is not overwritten")
check(oct(os.stat(work + "/exports").st_mode & 0o777) == "0o750", "exports/ is 0750")
PY

for f in imubench.db imubench.db-wal imubench.db-shm; do
  [[ -e $W/$f ]] || fail "$f missing"
  [[ $(mode_of "$W/$f") == 640 ]] || fail "$f mode $(mode_of "$W/$f"), want 640"
done
echo "ok: the database, -wal and -shm are 0640"

# The CLI sends the text of a plan outside the library; as another user it cannot read a file
# that user may not read (and never asks the daemon to).
"$CLI" start --dry-run "$W/private/mine.toml" >"$W/cli.out" 2>&1 || fail "CLI dry run: $(cat "$W/cli.out")"
grep -q "dry run: $W/private/mine.toml accepted" "$W/cli.out" || fail "CLI: $(cat "$W/cli.out")"
echo "ok: the CLI sends a plan outside the library as text"
if [[ $(id -u) == 0 ]]; then
  as_other=(setpriv --reuid=65534 --regid=65534 --clear-groups)
else
  chmod 0000 "$W/private/root-only.toml"  # not root: a file its owner may not read
  as_other=()
fi
if "${as_other[@]}" "$CLI" start --dry-run "$W/private/root-only.toml" >"$W/cli2.out" 2>&1; then
  fail "the CLI read a file its user may not read"
fi
grep -q "Permission denied" "$W/cli2.out" || fail "CLI as another user: $(cat "$W/cli2.out")"
grep -q "secret_api_token_key" "$W/cli2.out" && fail "the CLI echoed the file"
echo "ok: the CLI reads plans with its user's rights: $(cat "$W/cli2.out")"

# An existing database with a looser mode is tightened when the daemon opens it.
e2e_stop_daemon
chmod 0644 "$W/imubench.db"
e2e_start_daemon
[[ $(mode_of "$W/imubench.db") == 640 ]] || fail "existing database left at $(mode_of "$W/imubench.db")"
echo "ok: an existing 0644 database is tightened to 0640"
e2e_stop_daemon
echo "PASS"
