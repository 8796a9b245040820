#!/usr/bin/env bash
# Issue 27 item 3: the follow-up experiment through the real imubenchd on vcan. The virtual bench
# carries the navigation-grade truth (tests/tools/data/truth_nav_grade.json) whose table has
# concealed encoder zeros and a mounting error; the bench file says [explain] follow_up =
# "queue". The bundled direct plan (calibration = "direct") and the bundled 12-run plan
# (calibration = "pipeline") run at 20x; at each plan's end:
#   - a `follow_up` event arrives and a "follow_up" result (imubench-follow-up/1) is stored with
#     the run's results, designed within the bench file's [table] limits (30 deg/s, 10 deg/s^2);
#   - the encoder zeros and the mounting, which the recordings cannot separate from the
#     baseline and no motion of a two-axis table can (they need another reference or a change
#     of the set-up), are refused with that reason ("no plan");
#   - a proposal holding a plan is queued at once, runs by itself next, and after it the joint
#     analysis of both runs is stored with the follow-up's results ("follow_up_joint", event
#     follow_up_verdict): each group the proposal separates "resolved", each it could not "still
#     unseparable". (On this bench the direct run's outer-axis harmonic was proposed as
#     separated, ran, and came out still unseparable: the design had evaluated another harmonic
#     than explain judged; such a group is no longer claimed, daemon/follow_up.h, so today both
#     proposals are refused and this branch does not run);
#   - a refused proposal queues nothing and `imubench queue accept RUN` says it holds no plan; a
#     run without a proposal is refused as not found;
#   - `imubench results` shows the proposal on the origin run and the verdict on the follow-up.
# Not shown here: a concealed PAIR of the truth resolved (docs/explain.md "In the daemon": no
# pair found is both unseparable on the bundled plans and separable on a two-axis table). The
# pair case of the same code is checked on simulated recordings by FollowUp.* .
# Usage: follow_up.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
[[ -n ${E2E_KEEP:-} ]] && trap 'cp "$W"/imubench.db* "$E2E_KEEP/" 2>/dev/null; e2e_cleanup' EXIT

SCALE=${E2E_ONLINE_TIME_SCALE:-20}
e2e_navgrade_bench

e2e_bench_file "$(cat "$SRC/tools/demo_bench_limits.toml")
[explain]
follow_up = \"queue\""
grep -q '^follow_up = "queue"' "$W/bench.toml" || fail "bench file [explain]"
e2e_start_vb --time-scale "$SCALE" --truth "$TRUTH" --noise nav-grade --seed 3
e2e_start_daemon

PYTHONPATH="$SRC/tools/python" e2e_py "$CLI" <<'PY' || fail "follow-up"
import subprocess, sys
from e2e_client import Client, check
work, cli = sys.argv[1], sys.argv[2]

def imubench(*args):
    p = subprocess.run([cli, *args], capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr

c = Client(work + "/control.sock", timeout=500.0)
c.subscribe("run")

def stored(run):
    return {r["kind"]: r["json"] for r in c.reply({"cmd": "results", "run": run})["result"]["results"]}

def check_follow_up(run, ev, f):
    """The stored proposal of a plan's end: within the bench limits; the groups no table motion
    separates (the truth's encoder zeros and mounting) refused with the reason."""
    print("run %d follow-up: %s" % (run, ev["summary"]), flush=True)
    check(f["format"] == "imubench-follow-up/1", "run %d: format %s" % (run, f.get("format")))
    check(f["run"] == run and f["policy"] == "queue", "run %d: run and policy: %s" % (run, f))
    lim = f["limits"]
    check(abs(lim["max_rate_deg_s"] - 30) < 1e-9 and abs(lim["max_accel_deg_s2"] - 10) < 1e-9,
          "run %d: designed within the bench file's limits: %s" % (run, lim))
    check(ev["status"] == f["status"], "run %d: event and result agree: %s" % (run, ev))
    groups = {" + ".join(g["effects"]): g for g in f["groups"]}
    check(any("encoder_zero" in k for k in groups), "run %d: encoder_zero group: %s" % (run, list(groups)))
    check("mounting" in groups, "run %d: mounting group: %s" % (run, list(groups)))
    for k in [k for k in groups if "encoder_zero" in k or k == "mounting"]:
        g = groups[k]
        check(not g["resolved"] and not g["possible"] and "no plan within the bench limits" in g["why"],
              "run %d: %s refused with the reason: %s" % (run, k, g["why"]))
    if f["status"] == "proposed":
        check(any(g["unseparable"] and g["resolved"] for g in f["groups"]),
              "run %d: a proposal separates a group" % run)
        check(f["plan"]["name"] == "follow_up_of_run_%d" % run and "[[step]]" in f["plan"]["toml"],
              "run %d: plan %s" % (run, f["plan"]["name"]))
    else:
        check("plan" not in f and "no plan within the bench limits" in f["reason"],
              "run %d: refused with the reason: %s" % (run, f.get("reason")))

def check_verdict(origin, f):
    """A proposal under follow_up = "queue" runs by itself next; after it the joint analysis of
    both runs is stored with its results: each of the origin's groups resolved or not, those no
    plan separates still unseparable, those the plan separates resolved."""
    q = c.wait_event(lambda e: e["event"] == "queue_started" and e["plan"] == f["plan"]["name"],
                     "the follow-up of run %d started by itself" % origin, limit=120)
    run = q["run"]
    v = c.wait_event(lambda e: e["event"] == "follow_up_verdict" and e.get("run") == run,
                     "the joint verdict of run %d" % run, limit=500)
    print("run %d (follow-up of %d): %s" % (run, origin, v["summary"]), flush=True)
    check(v["ok"] and v["origin_run"] == origin, "run %d: verdict %s" % (run, v))
    j = stored(run)["follow_up_joint"]
    check(j["format"] == "imubench-follow-up-joint/1" and j["report"]["format"] == "imubench-explain/1",
          "run %d: joint result formats" % run)
    verdicts = {" + ".join(g["effects"]): g["verdict"] for g in j["groups"]}
    for g in f["groups"]:
        if not g["unseparable"]:
            continue
        k = " + ".join(g["effects"])
        want = "resolved" if g["resolved"] else "still unseparable"
        check(verdicts.get(k) == want, "run %d: %s %s (proposal: %s)" % (run, k, verdicts.get(k), want))
    return run

def run_plan(path):
    rc, out = imubench("start", path)
    check(rc == 0, "start %s: %s" % (path, out))
    run = int(out.split("started run ")[1].split()[0])
    res = c.wait_event(lambda e: e.get("run") == run and e["event"] == "results",
                       "results of run %d" % run, limit=500)
    check(res["ok"] and res["calibrated"], "run %d: results stored: %s" % (run, res))
    check("follow_up" in res["results"], "run %d: follow_up result stored: %s" % (run, res["results"]))
    ev = c.wait_event(lambda e: e.get("run") == run and e["event"] == "follow_up",
                      "follow_up of run %d" % run, limit=5)
    f = stored(run)["follow_up"]
    check_follow_up(run, ev, f)
    return run, f

followed = []
for path in (work + "/direct.toml", work + "/12run.toml"):
    run, f = run_plan(path)
    if f["status"] == "proposed":
        followed.append((run, check_verdict(run, f)))
    else:
        check(not c.reply({"cmd": "queue_list"})["result"]["queue"], "run %d: nothing queued" % run)
        rc, out = imubench("queue", "accept", str(run))
        check(rc != 0 and "run %d's follow-up holds no plan" % run in out,
              "queue accept %d refused: %s" % (run, out))
rc, out = imubench("queue", "accept", "99")
check(rc != 0 and "run 99 has no stored follow-up proposal" in out, "queue accept 99: %s" % out)
with open(work + "/followed", "w") as fh:
    fh.write("".join("%d %d\n" % f for f in followed))
PY

# The 12-run plan's stored follow-up as `results` shows it (run 2, or 3 after a follow-up).
last=$(python3 -c 'import sqlite3, sys
print(sqlite3.connect(sys.argv[1]).execute(
    "SELECT max(run_id) FROM results WHERE kind = ?", ("follow_up",)).fetchone()[0])' "$W/imubench.db")
out=$("$CLI" results "$last" --db "$W/imubench.db" 2>&1) || true
echo "$out"
grep -q '^follow-up (policy queue): ' <<<"$out" || fail "results $last: the follow-up shown"
grep -qE '^  mounting \(unseparable\): no plan: ' <<<"$out" || fail "results $last: the group's reason"
while read -r origin followed; do
  out=$("$CLI" results "$followed" --db "$W/imubench.db" 2>&1) || true
  echo "$out"
  grep -q "^follow-up of run $origin: joint explain over both runs$" <<<"$out" ||
    fail "results $followed: the joint verdict shown"
done <"$W/followed"
e2e_stop_daemon
echo "PASS"
