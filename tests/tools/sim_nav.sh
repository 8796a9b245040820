#!/bin/sh
# imubench simulate on a short plan, then imubench nav on the recording it wrote.
# Usage: sim_nav.sh IMUBENCH PLAN TRUTH WORKDIR NOISE MIN_ERR_M MAX_ERR_M
# The maximum horizontal position error printed by nav must lie in [MIN_ERR_M, MAX_ERR_M].
set -e
bin="$1"; plan="$2"; truth="$3"; work="$4"; noise="$5"; min_err="$6"; max_err="$7"
rm -rf "$work"; mkdir -p "$work"
"$bin" simulate "$plan" --truth "$truth" --out "$work/rec" --rate 100 --seed 3 --noise "$noise"
for f in meta.json imu.csv table.csv segments.csv; do
  [ -s "$work/rec/$f" ] || { echo "sim_nav.sh: $f missing" >&2; exit 1; }
done
# 100 Hz over 20 + 9 + 1 + 20 s ~ 5000 rows (+ header).
rows=$(wc -l < "$work/rec/imu.csv")
[ "$rows" -gt 4000 ] || { echo "sim_nav.sh: only $rows imu.csv lines" >&2; exit 1; }
if ! "$bin" nav "$work/rec" --every 10 --out "$work/nav.csv" > "$work/nav.txt"; then
  cat "$work/nav.txt"; exit 1
fi
cat "$work/nav.txt"
err=$(sed -n 's/^max horizontal position error: \(.*\) m$/\1/p' "$work/nav.txt")
[ -n "$err" ] || { echo "sim_nav.sh: no max error line" >&2; exit 1; }
awk -v e="$err" -v lo="$min_err" -v hi="$max_err" 'BEGIN { exit !(e >= lo && e <= hi) }' ||
  { echo "sim_nav.sh: max position error $err m outside [$min_err, $max_err]" >&2; exit 1; }
head -1 "$work/nav.csv" | grep -q '^t,v_E_err,v_N_err,d_E,d_N$'
lines=$(wc -l < "$work/nav.csv")
[ "$lines" -ge 6 ] || { echo "sim_nav.sh: nav.csv has $lines lines" >&2; exit 1; }
rm -rf "$work"
