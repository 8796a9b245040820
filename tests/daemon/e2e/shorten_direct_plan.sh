#!/usr/bin/env bash
# shorten_direct_plan.sh FILE: the bundled direct plan (plans/library/direct_two_axis.toml, or
# a copy of it) shortened in place for an e2e run: 30 s positions, 10 s around the rate runs,
# one-turn rate runs (9 s at 30 deg/s between 3 s ramps: 360 deg); the same positions, axes and
# directions, about 10 min of bench time instead of 34. Used by table_latency.sh at 1x and by
# tests/lab/lab_benches_e2e.sh. Fails (exit 1, with the reason) when the plan no longer has the
# durations it rewrites.
set -euo pipefail
f=${1:?usage: shorten_direct_plan.sh FILE}
sed -i -e 's/^duration = "30 s"/duration = "10 s"/' -e 's/^duration = "120 s"/duration = "30 s"/' \
  -e 's/^duration = "33 s"/duration = "9 s"/' "$f"
if [[ $(grep -c '^duration = "30 s"' "$f") -ne 12 ||
  $(grep -c '^duration = "\(10\|9\) s"' "$f") -ne 15 ]]; then
  echo "shorten_direct_plan.sh: $f: not the bundled direct plan's durations" \
    "(12 positions; 15 holds and turns of its rate runs)" >&2
  exit 1
fi
