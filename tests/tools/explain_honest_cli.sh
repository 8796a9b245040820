#!/bin/sh
# Honest output of `imubench explain` and `imubench calibrate` (issue 26, item 4):
#   1. a table recording at one orientation: explain refuses before any baseline, exit 3
#      ("result unusable", calibrate's code for the same kind of refusal);
#   2. the MPU-9150 log (100 Hz, no time column) read with --rate 50: refused by explain and by
#      calibrate (exit 3, the rate named); read at its own rate: analysed (exit 0);
#   3. --gyro-range below the log's rates: refused by both (exit 1, clipped samples);
#   4. too few static poses: the same exit code (3) from both;
#   5. noise-free data (simulated with --noise none): said, and no "within the noise floor";
#   6. no "sigma nan" and no internal parameter names ("nuisance.") in explain's output on the
#      real recordings.
# Usage: explain_honest_cli.sh IMUBENCH PLAN_DIR TEST_DATA_DIR REAL_DATA_DIR TRUTH WORKDIR
set -e
bin="$1"; plans="$2"; data="$3"; real="$4"; truth="$5"; work="$6"
rm -rf "$work"; mkdir -p "$work"
fail() { echo "explain_honest_cli.sh: $*" >&2; exit 1; }
# expect CODE REGEX command...: exit code and message
expect() {
  code="$1"; regex="$2"; shift 2
  set +e; out=$("$@" 2>&1); got=$?; set -e
  echo "$out" | tail -4
  [ "$got" = "$code" ] || fail "exit $got (expected $code): $*"
  echo "$out" | grep -Eq -- "$regex" || fail "message does not match /$regex/: $out"
}

"$bin" simulate "$data/one_orientation_plan.toml" --truth "$truth" --out "$work/one" --rate 50 \
  --seed 3 --noise nav-grade > /dev/null
expect 3 "cannot determine a calibration.*1 distinct attitude" "$bin" explain "$work/one"

mpu="$real/mikoff_mpu9150_imu0.log"
expect 3 "--rate 50 Hz is probably not" "$bin" explain "$mpu" --format mikov --rate 50
expect 3 "--rate 50 Hz is probably not" "$bin" calibrate "$mpu" --format mikov --rate 50
expect 0 "unexplained: " "$bin" explain "$mpu" --format mikov --rate 100

expect 1 "at or beyond the IMU's range 100 deg/s" "$bin" explain "$mpu" --format mikov \
  --gyro-range 100
expect 1 "at or beyond the IMU's range 100 deg/s" "$bin" calibrate "$mpu" --format mikov \
  --gyro-range 100

head -n 3000 "$mpu" > "$work/few_poses.log"
set +e
"$bin" calibrate "$work/few_poses.log" --format mikov > "$work/few_cal.txt" 2>&1; cal=$?
"$bin" explain "$work/few_poses.log" --format mikov > "$work/few_exp.txt" 2>&1; exp=$?
set -e
cat "$work/few_cal.txt" "$work/few_exp.txt" | tail -4
[ "$cal" = 3 ] || fail "calibrate on too few poses: exit $cal (expected 3)"
[ "$exp" = "$cal" ] || fail "explain on too few poses: exit $exp, calibrate $cal"

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/quiet" --rate 50 \
  --seed 12 --noise none > /dev/null
"$bin" explain "$work/quiet" --json "$work/quiet.json" > "$work/quiet.txt" 2>&1 ||
  { cat "$work/quiet.txt"; fail "explain on noise-free data failed"; }
grep -q "show no noise" "$work/quiet.txt" || { cat "$work/quiet.txt"; fail "noise-free not said"; }
if grep -q "within the noise floor" "$work/quiet.txt"; then fail "noise-free judged"; fi

for args in "$mpu --format mikov" \
  "$real/imucal_example_ferraris_session.csv --format imucal" \
  "$real/imutk_xsens_acc.txt --format imutk --gyro $real/imutk_xsens_gyro.txt"; do
  # shellcheck disable=SC2086
  "$bin" explain $args > "$work/real.txt" 2>&1 || { cat "$work/real.txt"; fail "explain $args"; }
  if grep -Eq "sigma nan|nuisance\." "$work/real.txt"; then
    grep -En "sigma nan|nuisance\." "$work/real.txt"; fail "internal names or nan in: $args"
  fi
done
echo PASS
