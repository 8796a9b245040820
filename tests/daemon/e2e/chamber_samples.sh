#!/usr/bin/env bash
# Issue 17, defect 6, through the real imubenchd on vcan: a run's chamber temperatures are
# stored. The bench file polls the chamber every 0.4 s ([chamber] poll_period); the virtual
# bench runs at 5x, so the stored chamber samples (on the IMU clock) are 2 s apart. A plan
# with a hold, a chamber step (20 -> 22 degC at 5 degC/min) and a hold runs to completion;
# the exported chamber.csv has rows 2 s apart across every step's interval, the setpoint of
# the chamber step from its start on, and temperatures the chamber can have.
# Usage: chamber_samples.sh <imubench-virtual-bench> <imubenchd> <imubench> <source dir>
set -euo pipefail
source "$4/tests/daemon/e2e/lib.sh"
e2e_init "$@"
E2E_CHAMBER_EXTRA='poll_period = "0.4 s"' e2e_bench_file
{
  e2e_plan_head chamber-samples
  e2e_plan_chamber -40 70 20
  e2e_hold h1 "20 s"
  cat <<'TOML'
[[step]]
type = "chamber"
setpoint = "22 degC"
ramp = "5 degC/min"
soak = "0 min"
label = "c1"
TOML
  e2e_hold h2 "20 s"
} >"$W/plan.toml"
e2e_start 5

e2e_py <<'PY' || fail "client checks"
import sys
from e2e_client import check, read_csv, start_run

work = sys.argv[1]
SPACING = 0.4 * 5  # poll period x time scale: chamber samples apart on the IMU clock
c = start_run(work, work + "/plan.toml")
run = c.run
fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == run, "run end", 120)
check(fin["state"] == "finished" and fin["exit"] == "completed", "the run completed")
exp = c.reply({"cmd": "export", "run": run, "dir": "export"})
check(exp["ok"], "export: %s" % exp)
import os
check(os.path.exists(work + "/exports/export/chamber.csv"), "chamber.csv exported")
rows = [(float(r["t"]), float(r["setpoint"]), float(r["temp"]))
        for r in read_csv(work + "/exports/export/chamber.csv")]
segs = read_csv(work + "/exports/export/segments.csv")
check([s["label"] for s in segs] == ["h1", "c1", "h2"], "three steps stored")
ts = [r[0] for r in rows]
gaps = sorted(b - a for a, b in zip(ts, ts[1:]))
check(len(gaps) > 10, "%d chamber samples" % len(rows))
median = gaps[len(gaps) // 2]
check(abs(median - SPACING) < 0.3, "chamber samples %.2f s apart (poll period 0.4 s at 5x)" % median)
check(gaps[-1] < 2.5 * SPACING, "no gap in the chamber samples: largest %.2f s" % gaps[-1])
for s in segs:
    t0, t1 = float(s["t0"]), float(s["t1"])
    inside = [t for t in ts if t0 <= t <= t1]
    want = int((t1 - t0) / SPACING) - 1
    check(len(inside) >= want and inside[0] - t0 < 1.5 * SPACING and t1 - inside[-1] < 1.5 * SPACING,
          "step %s (%.1f s): %d chamber samples across it, %d expected" % (s["label"], t1 - t0,
                                                                           len(inside), want + 1))
c1 = next(s for s in segs if s["label"] == "c1")
later = [r for r in rows if r[0] >= float(c1["t0"]) + 1.5 * SPACING]
check(later and all(abs(r[1] - 22.0) < 0.05 for r in later), "setpoint 22 degC from the chamber step on")
check(all(15.0 < r[2] < 25.0 for r in rows), "chamber temperatures between 15 and 25 degC")
PY
e2e_stop_daemon
echo PASS
