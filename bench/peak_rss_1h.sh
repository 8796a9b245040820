#!/usr/bin/env bash
# Peak memory of `imubench calibrate` and `imubench explain` on an hour at 2 kHz (issue 31:
# each under 1 GiB). The production pipeline's two recordings, simulated at 2 kHz by the
# CLI under test: the direct two-axis plan (~33 min) and the 12-run plan (~29 min), 62 min and
# 7.48 M IMU rows together. Measured per command with /usr/bin/time (the whole process: the
# read of both recordings, the calibration or analysis, the report): wall, CPU, peak RSS.
#   calibrate  NAV --method indirect --direct DIRECT   the pipeline over both recordings
#   explain    NAV --direct DIRECT                     the direct calibration as the baseline,
#                                                      then the analysis of the 12-run recording
# Usage: bench/peak_rss_1h.sh [BUILD_DIR] [WORK_DIR]   (default: build, a temp dir under /tmp;
#        needs the imubench-cli target; WORK_DIR keeps the recordings for the next run)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
cli=$build/tools/imubench-cli
[[ -x $cli ]] || { echo "bench/peak_rss_1h.sh: $cli not built" >&2; exit 2; }
work=${2:-}
if [[ -z $work ]]; then
  work=$(mktemp -d "${TMPDIR:-/tmp}/imubench-rss1h.XXXXXX")
  trap 'rm -rf "$work"' EXIT
fi
limit_mib=1024
truth=$here/tests/tools/data/truth_nav_grade.json
plans=$here/plans/library

simulate() {  # plan, dir
  [[ -f $work/$2/imu.csv ]] && return 0
  "$cli" simulate "$plans/$1.toml" --truth "$truth" --out "$work/$2" --rate 2000 \
    --noise nav-grade >/dev/null
}
simulate direct_two_axis direct
simulate two_axis_12run nav
rows=$(($(wc -l <"$work/direct/imu.csv") + $(wc -l <"$work/nav/imu.csv") - 2))

measure() {  # name, command...
  local name=$1
  shift
  local t=$work/$name.time
  /usr/bin/time -f "%e %U %S %M" -o "$t" "$@" >"$work/$name.out" 2>&1 ||
    { echo "bench/peak_rss_1h.sh: $name failed:" >&2; tail -5 "$work/$name.out" >&2; return 1; }
  read -r wall user sys rss_kib <"$t"
  awk -v n="$name" -v w="$wall" -v u="$user" -v s="$sys" -v r="$rss_kib" -v l="$limit_mib" \
    'BEGIN { m = r / 1024; printf "%-10s wall %7.2f s  cpu %7.2f s  peak_rss %7.1f MiB  %.2f of the %d MiB target  %s\n",
             n, w, u + s, m, m / l, l, (m < l ? "MET" : "MISSED") }'
}
echo "1 h at 2 kHz: $rows IMU rows (direct + 12-run), $cli"
measure calibrate "$cli" calibrate "$work/nav" --method indirect --direct "$work/direct"
measure explain "$cli" explain "$work/nav" --direct "$work/direct" --json "$work/explain.json"
