#!/usr/bin/env bash
# Runs under tools/vcan-run.sh (a vcan0 exists): the virtual bench streams the simulated IMU
# as CAN frames in the SBG ECAN layout while its table is commanded over Modbus TCP; candump
# (can-utils, not ours) must see the layout's three frame ids, at the layout's rate from the
# sample counter: 100 Hz x 3 frames for 2 s of a 1x clock = about 600 frames.
# Usage: virtual_bench_imu_vcan.sh <imubench-virtual-bench> <drivers/devices dir>
set -euo pipefail
BENCH=$1
DEV=$2
. "$(dirname "$0")/virtual_bench_lib.sh"
start_virtual_bench "$BENCH" --table "$DEV/tables/imubench-ref-2axis-tcp.toml" \
  --chamber "$DEV/chambers/generic-float-chamber.toml" --table-port 0 --chamber-port 0 \
  --imu "$DEV/imus/sbg_ecan.toml" --can vcan0 --time-scale 1
cat "$OUT/stdout"
# candump: stop after 600 frames, or after 5 s without any frame.
candump -n 600 -T 5000 vcan0 >"$OUT/dump" || true
n=$(wc -l <"$OUT/dump")
echo "candump received $n frames"
[ "$n" -eq 600 ] || fail "expected 600 frames, got $n"
for id in 120 121 122; do
  c=$(grep -c " $id " "$OUT/dump" || true)
  echo "id 0x$id: $c frames"
  [ "$c" -ge 190 ] || fail "too few frames with id 0x$id"
done
