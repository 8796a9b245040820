#!/usr/bin/env bash
# A third-party Modbus client (mbpoll) reads and writes the virtual table's registers at the
# addresses, types, word order and codes the device file gives (read from the TOML file here
# with Python's tomllib, not from our code): close the interlock, put the outer axis in
# position mode, write a float demand, command the move, and poll until the float position
# register reads the demand and the axis status says in-position.
# Usage: mbpoll_virtual_table.sh <imubench-virtual-bench> <drivers/devices dir>
set -euo pipefail
BENCH=$1
DEV=$2
TABLE=$DEV/tables/imubench-ref-2axis-tcp.toml
CHAMBER=$DEV/chambers/generic-float-chamber.toml
TARGET=123.5

# One Python call reads every address/code the test needs from the device file.
eval "$(python3 - "$TABLE" <<'PY'
import sys, tomllib
d = tomllib.load(open(sys.argv[1], "rb"))
r, a0 = d["registers"], d["registers"]["axis"][0]
vals = {
    "ORDER": r["word_order"], "STATUS": r["status"]["address"],
    "CONTROL": r["control"]["address"], "MODE": a0["mode"]["address"],
    "COMMAND": a0["command"]["address"], "DEMAND": a0["position_demand"]["address"],
    "POSITION": a0["position"]["address"], "AXSTATUS": a0["status"]["address"],
    "CLOSE": d["codes"]["ctl_interlock_close"], "POSMODE": d["codes"]["mode_position"],
    "MOVE": d["codes"]["cmd_move"], "BIT_CLOSED": d["status_bits"]["interlock_closed"],
    "BIT_INPOS": d["status_bits"]["axis_in_position"],
}
for k, v in vals.items():
    print(f"{k}={v}")
PY
)"
[ "$ORDER" = high-first ] || { echo "test expects a high-first word order"; exit 1; }

. "$(dirname "$0")/virtual_bench_lib.sh"
start_virtual_bench "$BENCH" --table "$TABLE" --chamber "$CHAMBER" --table-port 0 \
  --chamber-port 0 --time-scale 20
PORT=$(sed -n 's/^table modbus-tcp [0-9.]*:\([0-9]*\) .*/\1/p' "$OUT/stdout")
[ -n "$PORT" ] || fail "no table port announced"
echo "virtual table on 127.0.0.1:$PORT"

mb() { mbpoll -m tcp -p "$PORT" -a 1 -0 -1 -o 2 "$@"; }
value() {  # value <mbpoll read args...>: the first value printed as "[addr]: value"
  mb "$@" 127.0.0.1 | sed -n 's/^\[[0-9]*\]:[[:space:]]*\([-+0-9.eE]*\).*/\1/p' | head -1
}

mb -r "$CONTROL" -t 4 127.0.0.1 "$CLOSE" >/dev/null || fail "write control"
st=$(value -r "$STATUS" -t 4)
echo "status register: $st"
(( (st >> BIT_CLOSED) & 1 )) || fail "interlock not closed after writing code $CLOSE"
mb -r "$MODE" -t 4 127.0.0.1 "$POSMODE" >/dev/null || fail "write mode"
mb -r "$DEMAND" -t 4:float -B 127.0.0.1 "$TARGET" >/dev/null || fail "write demand"
demand=$(value -r "$DEMAND" -t 4:float -B)
echo "demand read back: $demand"
awk -v v="$demand" -v t="$TARGET" 'BEGIN { d = v - t; exit !(d < 1e-4 && d > -1e-4) }' ||
  fail "demand read back $demand"
mb -r "$COMMAND" -t 4 127.0.0.1 "$MOVE" >/dev/null || fail "write command"

for _ in $(seq 300); do
  pos=$(value -r "$POSITION" -t 4:float -B)
  ax=$(value -r "$AXSTATUS" -t 4)
  if awk -v v="$pos" -v t="$TARGET" 'BEGIN { d = v - t; exit !(d < 1e-3 && d > -1e-3) }' &&
    (( (ax >> BIT_INPOS) & 1 )); then
    echo "position register reads $pos deg, axis status $ax: in position"
    exit 0
  fi
  sleep 0.1
done
fail "position register reads $pos (axis status $ax), expected $TARGET"
