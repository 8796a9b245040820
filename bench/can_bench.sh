#!/usr/bin/env bash
# CAN IMU benchmarks in one run:
#  1. decode path, raw frames -> samples, one core (Google Benchmark; target >= 5 M frames/s,
#     over 500x the ~9,000 frames/s classic-CAN ceiling at 1 Mbit/s);
#  2. the virtual IMU streaming over vcan0 to the reader (frames/s, reader CPU per frame, lost
#     samples), inside user-mode-linux when the host has no vcan (tools/vcan-run.sh).
# Usage: bench/can_bench.sh [BUILD_DIR]   (default: build)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
bin=$build/bench/drivers/imubench_can_bench
if [[ ! -x $bin ]]; then
  echo "can_bench.sh: $bin not built (cmake --build $build --target imubench_can_bench)" >&2
  exit 1
fi
echo "== decode (host, one core) =="
"$bin" --benchmark_filter='BM_Decode' --benchmark_min_time=0.5
echo "== vcan stream (tools/vcan-run.sh: host vcan or user-mode-linux) =="
"$here/tools/vcan-run.sh" "$bin" --benchmark_filter='BM_VcanStream'
