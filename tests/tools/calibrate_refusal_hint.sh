#!/bin/sh
# What `imubench calibrate` says to do when it refuses a fit (exit 3, nothing written):
#   1. the 12-run recording alone, noise only: its residuals are at the noise but its motion
#      leaves coefficients undetermined. The hint must say no missing effect explains this
#      and point at what a plan determines, never send the operator to `imubench explain`.
#   2. the direct plan on a table with errors, forced to zero (--table-errors): the residuals
#      are far above the noise, and the hint names `imubench explain`.
# Usage: calibrate_refusal_hint.sh IMUBENCH PLAN_DIR TRUTH WORKDIR
set -u
bin="$1"; plans="$2"; truth="$3"; work="$4"
fail() { echo "calibrate_refusal_hint.sh: $*" >&2; exit 1; }
# refused LABEL NAME ARGS...: `imubench calibrate ARGS --out $work/NAME.json` exits 3 and writes
# nothing; its output is left in $work/NAME.txt.
refused() {
  label="$1"; name="$2"; shift 2
  "$bin" calibrate "$@" --out "$work/$name.json" > "$work/$name.txt" 2>&1; rc=$?
  cat "$work/$name.txt"
  [ "$rc" = 3 ] || fail "$label: exit $rc, expected 3"
  [ ! -e "$work/$name.json" ] || fail "$label: a coefficient file was written"
}
rm -rf "$work"; mkdir -p "$work"
"$bin" simulate "$plans/two_axis_12run.toml" --truth "$truth" --out "$work/r12" --rate 100 \
  --seed 3 --noise nav-grade > /dev/null || fail "simulate the 12-run"
refused "12-run alone" r12 "$work/r12"
grep -q "not determined by the data" "$work/r12.txt" || fail "12-run alone: no undetermined finding"
grep -q "within the noise limit, so no missing effect" "$work/r12.txt" ||
  fail "12-run alone: the hint does not say the residuals are at the noise"
! grep -q "imubench explain" "$work/r12.txt" ||
  fail "12-run alone: the hint sends the operator to explain for an undetermined coefficient"

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/direct" --rate 100 \
  --seed 4 --noise nav-grade > /dev/null || fail "simulate the direct plan"
printf '{"table": {"base_tilt": [0, 0], "nonorthogonality": [0], "mounting": [0, 0], "encoder_zero": [0, 0]}}\n' \
  > "$work/zero.json"
refused "direct, table forced to zero" direct "$work/direct" --method direct \
  --table-errors "$work/zero.json"
grep -q "normalised residual RMS" "$work/direct.txt" || fail "direct: no misfit finding"
grep -q "imubench explain .* names the effect the model lacks" "$work/direct.txt" ||
  fail "direct, table forced to zero: no explain hint"
echo "calibrate_refusal_hint.sh: PASS"
