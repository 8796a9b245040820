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
rm -rf "$work"; mkdir -p "$work"
"$bin" simulate "$plans/two_axis_12run.toml" --truth "$truth" --out "$work/r12" --rate 100 \
  --seed 3 --noise nav-grade > /dev/null || fail "simulate the 12-run"
"$bin" calibrate "$work/r12" --out "$work/r12.json" > "$work/r12.txt" 2>&1; rc=$?
cat "$work/r12.txt"
[ "$rc" = 3 ] || fail "12-run alone: exit $rc, expected 3"
[ ! -e "$work/r12.json" ] || fail "12-run alone: a coefficient file was written"
grep -q "not determined by the data" "$work/r12.txt" || fail "12-run alone: no undetermined finding"
grep -q "within the noise limit, so no missing effect" "$work/r12.txt" ||
  fail "12-run alone: the hint does not say the residuals are at the noise"
! grep -q "imubench explain" "$work/r12.txt" ||
  fail "12-run alone: the hint sends the operator to explain for an undetermined coefficient"

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/direct" --rate 100 \
  --seed 4 --noise nav-grade > /dev/null || fail "simulate the direct plan"
printf '{"table": {"base_tilt": [0, 0], "nonorthogonality": [0], "mounting": [0, 0], "encoder_zero": [0, 0]}}\n' \
  > "$work/zero.json"
"$bin" calibrate "$work/direct" --method direct --table-errors "$work/zero.json" \
  --out "$work/direct.json" > "$work/direct.txt" 2>&1; rc=$?
cat "$work/direct.txt"
[ "$rc" = 3 ] || fail "direct, table forced to zero: exit $rc, expected 3"
[ ! -e "$work/direct.json" ] || fail "direct, table forced to zero: a coefficient file was written"
grep -q "normalised residual RMS" "$work/direct.txt" || fail "direct: no misfit finding"
grep -q "imubench explain .* names the effect the model lacks" "$work/direct.txt" ||
  fail "direct, table forced to zero: no explain hint"
echo "calibrate_refusal_hint.sh: PASS"
