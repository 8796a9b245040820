#!/usr/bin/env bash
# The README's first command: set up the machine, build, and run the main job on the bench
# daemon: the virtual bench (known truth, navigation-grade noise) and imubenchd on a virtual CAN
# bus (inside user-mode Linux where the host has no CAN; tools/vcan-run.sh) run the bundled
# direct plan and then the bundled 12-run two-axis plan at an accelerated time scale; the
# daemon calibrates while they run (progress bar and estimates) and at their end (stored
# results); the stored calibration is printed against the virtual bench's truth (3 arcsec /
# 10 ppm / 2 sigma per parameter) with the pass/fail verdict of the bench's acceptance limits.
#   bash tools/demo.sh [--out DIR]     DIR/coefficients.json and DIR/truth.json (interchange.md)
# Environment: DEMO_TIME_SCALE (default 20) how much faster than the wall clock the bench runs.
set -euo pipefail
cd "$(dirname "$0")/.."
out=
while [[ $# -gt 0 ]]; do
  case $1 in
    --out) out=${2:?--out needs a directory}; shift 2 ;;
    --out=*) out=${1#--out=}; shift ;;
    *) echo "usage: bash tools/demo.sh [--out DIR]" >&2; exit 2 ;;
  esac
done
./tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build --target imubench imubench-store imubenchd imubench-virtual-bench \
  -j "$(nproc)"
if [[ -n $out ]]; then
  mkdir -p "$out"
  out=$(cd "$out" && pwd)
fi
exec ./tools/vcan-run.sh "$PWD/tools/demo_bench.sh" "$PWD" "$out"
