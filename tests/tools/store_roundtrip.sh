#!/bin/sh
# Run ids on the command line: simulate the direct plan, `imubench import` it into a fresh
# store, `imubench export` it back and require byte-identical files (the store keeps doubles
# bit-exactly); `imubench calibrate RUN --db` (N, run:N, $IMUBENCH_DB) must print the same
# coefficient JSON as `calibrate DIR`; --store-result stores them and `export --results` gives
# them back; bad run ids and paths are refused with messages naming them.
# Usage: store_roundtrip.sh IMUBENCH PLAN_DIR TRUTH
set -e
bin="$1"; plans="$2"; truth="$3"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
db="$work/runs.db"
fail() { echo "store_roundtrip.sh: $*" >&2; exit 1; }

# expect CODE REGEX command...: exit code and a stdout+stderr match (like expect.sh).
expect() {
  want="$1"; regex="$2"; shift 2
  set +e
  out=$("$@" 2>&1); code=$?
  set -e
  printf '%s\n' "$out"
  [ "$code" = "$want" ] || fail "exit code $code, expected $want: $*"
  printf '%s\n' "$out" | grep -Eq -- "$regex" || fail "output does not match /$regex/: $*"
}

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/rec" --rate 20 \
  --seed 7 --noise nav-grade > /dev/null

# import: the new run id alone on stdout; a second import gets the next id.
run=$("$bin" import "$work/rec" --db "$db" --plan-name direct_two_axis)
case "$run" in '' | *[!0-9]*) fail "import printed '$run', not a run id" ;; esac
run2=$("$bin" import "$work/rec" --db "$db" --serial OTHER-SN)
[ "$run2" -eq $((run + 1)) ] || fail "second import is run $run2, expected $((run + 1))"

# runs: both listed, finished, with plan and serial.
"$bin" runs --db "$db" | tee "$work/runs.txt"
grep -Eq "^ +$run +finished .* direct_two_axis " "$work/runs.txt" || fail "runs: no row for $run"
grep -Eq "^ +$run2 +finished .* OTHER-SN " "$work/runs.txt" || fail "runs: no row for $run2"
"$bin" runs --db "$db" --json > "$work/runs.json"
python3 - "$work/runs.json" "$run" <<'PY'
import json, sys
runs = json.load(open(sys.argv[1]))
r = [x for x in runs if x["id"] == int(sys.argv[2])]
assert len(runs) == 2 and len(r) == 1, runs
assert r[0]["state"] == "finished" and r[0]["plan_name"] == "direct_two_axis", r[0]
assert r[0]["exit_reason"] == "imported" and r[0]["table_kind"] == "two-axis", r[0]
PY

# export: the same files, byte for byte.
"$bin" export "$run" --csv "$work/out" --db "$db"
(cd "$work/rec" && ls) > "$work/files.rec"
(cd "$work/out" && ls) > "$work/files.out"
cmp "$work/files.rec" "$work/files.out" || fail "exported file set differs"
for f in $(cat "$work/files.rec"); do
  cmp "$work/rec/$f" "$work/out/$f" || fail "exported $f differs from the original"
done
echo "export of run $run: $(wc -l < "$work/files.rec") files byte-identical to the original"

# calibrate on the run id = calibrate on the directory (direct method: quick; the simulated
# table has errors, given with --table-errors, without which direct calibration is unusable).
"$bin" calibrate "$work/rec" --method direct --table-errors "$truth" --json > "$work/coef_dir.json" 2> /dev/null
"$bin" calibrate "$run" --db "$db" --method direct --table-errors "$truth" --json > "$work/coef_run.json" 2> /dev/null
cmp "$work/coef_dir.json" "$work/coef_run.json" || fail "calibrate $run differs from calibrate DIR"
IMUBENCH_DB="$db" "$bin" calibrate "run:$run" --method direct --table-errors "$truth" --json > "$work/coef_env.json" \
  2> /dev/null
cmp "$work/coef_dir.json" "$work/coef_env.json" || fail "calibrate run:$run via IMUBENCH_DB differs"
# The indirect method's --direct takes a run id as well (same recording both ways here).
"$bin" calibrate "$work/rec" --direct "$work/rec" --json > "$work/pipe_dir.json" 2> /dev/null
"$bin" calibrate "$work/rec" --direct "run:$run" --db "$db" --json > "$work/pipe_run.json" \
  2> /dev/null
cmp "$work/pipe_dir.json" "$work/pipe_run.json" || fail "calibrate --direct run:$run differs"
echo "calibrate on run $run (N, run:N, IMUBENCH_DB, --direct) = calibrate on the directory"

# --store-result: stored as kind "coefficients" with the serial and mean temperature.
expect 0 "coefficients stored as result [0-9]+ of run $run in " \
  "$bin" calibrate "$run" --db "$db" --method direct --table-errors "$truth" --store-result
"$bin" export "$run" --csv "$work/out2" --db "$db" --results "$work/results.json"
python3 - "$work/results.json" "$work/coef_dir.json" "$work/rec/meta.json" "$run" <<'PY'
import json, sys
results = json.load(open(sys.argv[1]))
coef = json.load(open(sys.argv[2]))
coef.pop("calibration", None)  # --json adds the method's report beside the coefficients
meta = json.load(open(sys.argv[3]))
assert len(results) == 1, results
r = results[0]
assert r["run_id"] == int(sys.argv[4]) and r["kind"] == "coefficients", r
assert r["imu_serial"] == meta["imu"]["serial"], (r["imu_serial"], meta)
assert abs(r["temperature_c"] - 20.0) < 1e-9, r["temperature_c"]  # simulated bench at 20 degC
assert r["json"] == coef, "stored coefficients differ from calibrate --json"
print("stored result:", r["kind"], r["imu_serial"], r["temperature_c"], "degC")
PY
expect 2 "--store-result needs a run id" \
  "$bin" calibrate "$work/rec" --db "$db" --method direct --table-errors "$truth" --store-result

# Errors name what they refuse.
expect 1 "run 999 not found" "$bin" calibrate 999 --db "$db" --method direct
expect 1 "run 999 not found" "$bin" calibrate "$work/rec" --direct run:999 --db "$db"
expect 1 "run 999 not found" "$bin" export 999 --csv "$work/never" --db "$db"
expect 1 "'$work/no_such_dir' is neither a recording directory \(no such directory\) nor a run id" \
  "$bin" calibrate "$work/no_such_dir" --db "$db"
expect 1 "'run:x' is neither a recording directory" "$bin" calibrate run:x --db "$db"
expect 1 "$work/no_such.db: no run store" "$bin" calibrate 1 --db "$work/no_such.db"
expect 1 "$work/no_such.db: no run store" "$bin" runs --db "$work/no_such.db"
[ ! -e "$work/no_such.db" ] || fail "a reading command created $work/no_such.db"
expect 2 "'0' is not a run id" "$bin" export 0 --csv "$work/never" --db "$db"
: > "$work/a_file"
expect 1 "$work/a_file" "$bin" export "$run" --csv "$work/a_file/rec" --db "$db"
expect 1 "$work/no_such_rec" "$bin" import "$work/no_such_rec" --db "$db"
echo "store_roundtrip.sh: ok"
