#!/bin/sh
# `imubench simulate --thermal-truth`, `thermal fit` and `apply` through the binary:
#   - a plan with the direct plan at 0 and 40 degC (soak between) -> fit -> comp.json/csv;
#   - --report DIR (both methods): report.html self-contained (no http), one <svg> per
#     coefficient (24), the calibrated range of comp.json and its extrapolation flag; the
#     points method's plots carry the points;
#   - apply at 50 degC: every sample flagged as extrapolated (exit 0, warning, spans file);
#     apply at 0..40 degC: none flagged;
#   - refusals (exit 1, message naming the file and why): a recording without temperatures,
#     a single temperature point, recordings of different IMU serials, a compensation file
#     for another IMU serial.
# Usage: thermal_cli.sh IMUBENCH PLAN_DIR WORKDIR
set -e
bin="$1"; plans="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"
fail() { echo "thermal_cli.sh: $*" >&2; exit 1; }

# Thermal truth: linear in every coefficient, c0 = an ideal-ish sensor, hysteresis on biases.
python3 - "$work/truth.json" <<'PY'
import json, sys
def P(c0, c1, h=None):
    p = {"poly": [c0, c1]}
    if h is not None: p["dTdt"] = h
    return p
def triad(b, k):
    return {"scale": [P(1.0 + 1e-4 * i, 2e-6) for i in range(3)],
            "bias": [P(b * (i + 1), k, 0.0) for i in range(3)],
            "misalignment": {n: P(1e-4, 1e-6) for n in ["xy", "xz", "yx", "yz", "zx", "zy"]}}
json.dump({"format": "imubench-thermal/1", "imu": {"serial": ""}, "t_ref_c": 20,
           "range_c": [-40, 80], "accel": triad(0.01, 1e-4), "gyro": triad(1e-6, 1e-8)},
          open(sys.argv[1], "w"))
PY

# The direct plan at each setpoint of $2.. (chamber soak before each), written to $1.
plan() {
  out="$1"; shift
  python3 - "$plans/direct_two_axis.toml" "$out" "$@" <<'PY'
import re, sys
src = open(sys.argv[1]).read()
head, steps = src.split("[[step]]", 1)
steps = "[[step]]" + steps
head = head.replace('name = "direct_two_axis"', 'name = "thermal_cli"')
head += '\n[chamber]\nmin_temp = "-40 degC"\nmax_temp = "70 degC"\nmax_ramp = "10 degC/min"\ninitial = "20 degC"\n\n'
body = ""
for sp in sys.argv[3:]:
    body += '[[step]]\ntype = "chamber"\nsetpoint = "%s degC"\nramp = "10 degC/min"\nsoak = "5 min"\nlabel = "T%sC_soak"\n\n' % (sp, sp)
    body += re.sub(r'label = "([^"]*)"', lambda m: 'label = "T%sC_%s"' % (sp, m.group(1)), steps) + "\n"
open(sys.argv[2], "w").write(head + body)
PY
}
echo "{}" > "$work/base.json"
plan "$work/two.toml" 0 40
plan "$work/hot.toml" 50
sim() {  # plan out seed
  "$bin" simulate "$1" --truth "$work/base.json" --thermal-truth "$work/truth.json" --out "$2" \
    --rate 10 --table-rate 10 --seed "$3" --noise nav-grade > /dev/null 2> "$work/sim.err" ||
    { cat "$work/sim.err"; fail "simulate $1 failed"; }
}
sim "$work/two.toml" "$work/two" 3
sim "$work/hot.toml" "$work/hot" 3
sim "$work/hot.toml" "$work/other" 4

# Fit on two temperature points.
"$bin" thermal fit "$work/two" --out "$work/comp.json" --csv "$work/comp.csv" > "$work/fit.txt" ||
  fail "thermal fit failed: $(cat "$work/fit.txt")"
grep -q '"imubench-thermal/1"' "$work/comp.json" || fail "comp.json has no format"
grep -q "joint fit of every static and rate run" "$work/fit.txt" || fail "default is not the joint fit"
# The per-point fit stays available.
"$bin" thermal fit "$work/two" --method points --out "$work/comp_points.json" > "$work/fitp.txt" ||
  fail "thermal fit --method points failed: $(cat "$work/fitp.txt")"
grep -q "point 1" "$work/fitp.txt" || fail "--method points printed no points"
grep -q '"SIM-3"' "$work/comp.json" || fail "comp.json has no IMU serial"

# The report (issue 16 item 3): both methods.
"$bin" thermal fit "$work/two" --out "$work/comp_r.json" --report "$work/rep_joint" \
  > "$work/fitr.txt" || fail "thermal fit --report failed: $(cat "$work/fitr.txt")"
"$bin" thermal fit "$work/two" --method points --out "$work/comp_rp.json" \
  --report "$work/rep_points" > "$work/fitrp.txt" ||
  fail "thermal fit --method points --report failed: $(cat "$work/fitrp.txt")"
check_report() {  # comp.json report.html min-markers-per-plot
  python3 - "$@" <<'PY2' || fail "report $2: see above"
import json, re, sys
comp, html, min_markers = json.load(open(sys.argv[1])), open(sys.argv[2]).read(), int(sys.argv[3])
t0, t1 = comp["range_c"]
errors = []
if "http" in html.lower(): errors.append("refers to http: not self-contained")
if "<script" in html.lower(): errors.append("has a script")
plots = html.split("<svg")[1:]
if len(plots) != 24: errors.append("%d <svg> plots, expected 24" % len(plots))
if "Calibrated range: %.2f .. %.2f degC." % (t0, t1) not in html:
    errors.append("no 'Calibrated range: %.2f .. %.2f degC.'" % (t0, t1))
if "Outside it the model extrapolates" not in html: errors.append("no extrapolation flag")
for name in ["accel.scale.x", "accel.bias.z", "gyro.bias.x", "gyro.misalignment.zy"]:
    if "<h3>%s (order" % name not in html: errors.append("no plot titled " + name)
for i, p in enumerate(plots):
    p = p.split("</svg>")[0]
    if p.count("extrapolated (held)") != 2: errors.append("plot %d: range edges not marked" % i)
    markers = p.count("<circle") + p.count("<polygon fill='#c0392b'") + p.count("<polygon fill='#1f5fbf'")
    if markers < min_markers: errors.append("plot %d: %d point markers, expected >= %d" % (i, markers, min_markers))
if errors: sys.exit("\n".join(errors))
PY2
}
check_report "$work/comp_r.json" "$work/rep_joint/report.html" 0
check_report "$work/comp_rp.json" "$work/rep_points/report.html" 2
grep -q "and $work/rep_joint/report.html" "$work/fitr.txt" || fail "fit did not say it wrote the report"
[ "$(wc -l < "$work/comp.csv")" -eq 25 ] || fail "comp.csv: expected header + 24 rows"
# Two temperatures: a straight line per coefficient, the truth's slope (bias 1e-4 m/s^2/degC,
# scale 2e-6 /degC) within 5 %.
python3 - "$work/comp.json" <<'PY' || fail "fitted slopes differ from the truth"
import json, sys
c = json.load(open(sys.argv[1]))
for name, p, want in [("accel.bias.x", c["accel"]["bias"][0], 1e-4),
                      ("gyro.bias.z", c["gyro"]["bias"][2], 1e-8),
                      ("accel.scale.y", c["accel"]["scale"][1], 2e-6)]:
    got = p["poly"][1] if len(p["poly"]) > 1 else 0.0
    if abs(got / want - 1) > 0.05:
        sys.exit("%s: slope %g, truth %g" % (name, got, want))
PY

# Apply: inside the range nothing flagged, at 50 degC all flagged.
"$bin" apply "$work/comp.json" "$work/two" --out "$work/two_comp" > /dev/null 2> "$work/in.err" ||
  fail "apply failed: $(cat "$work/in.err")"
grep -q EXTRAPOLATED "$work/in.err" && fail "apply inside the range flagged extrapolation"
[ "$(wc -l < "$work/two_comp/extrapolated.csv")" -eq 1 ] || fail "spans listed inside the range"
"$bin" apply "$work/comp.json" "$work/hot" --out "$work/hot_comp" > /dev/null 2> "$work/hot.err" ||
  fail "apply at 50 degC failed: $(cat "$work/hot.err")"
grep -q "EXTRAPOLATED: .* samples outside the calibrated range" "$work/hot.err" ||
  fail "apply at 50 degC did not flag extrapolation: $(cat "$work/hot.err")"
[ "$(wc -l < "$work/hot_comp/extrapolated.csv")" -ge 2 ] || fail "no extrapolated span listed"

# Refusals: exit 1 and the file named with the reason.
expect_refusal() {  # pattern command...
  pat="$1"; shift
  if "$@" > "$work/r.out" 2> "$work/r.err"; then fail "accepted: $*"; fi
  code=$?
  grep -q -- "$pat" "$work/r.err" || fail "expected '$pat' from: $* -- got: $(cat "$work/r.err")"
}
expect_refusal "$work/hot: a single temperature point" \
  "$bin" thermal fit "$work/hot" --out "$work/x.json"
expect_refusal "$work/other: IMU serial 'SIM-4' differs from 'SIM-3'" \
  "$bin" thermal fit "$work/two" "$work/other" --out "$work/x.json"
expect_refusal "comp.json: compensation file for IMU serial 'SIM-3', but $work/other" \
  "$bin" apply "$work/comp.json" "$work/other" --out "$work/x"
cp -r "$work/two" "$work/notemp"
python3 - "$work/notemp/imu.csv" <<'PY'
import sys
lines = open(sys.argv[1]).read().splitlines()
out = [lines[0]] + [l.rsplit(",", 1)[0] + "," for l in lines[1:]]
open(sys.argv[1], "w").write("\n".join(out) + "\n")
PY
expect_refusal "$work/notemp: the recording has no IMU temperatures" \
  "$bin" thermal fit "$work/notemp" --out "$work/x.json"
expect_refusal "$work/notemp/imu.csv: sample 1 .* has no temperature" \
  "$bin" apply "$work/comp.json" "$work/notemp" --out "$work/x"
expect_refusal "--report $work/comp.csv: exists and is not a directory" \
  "$bin" thermal fit "$work/two" --out "$work/x.json" --report "$work/comp.csv"
[ -e "$work/x.json" ] && fail "a refused fit wrote its output"
echo "thermal_cli.sh: ok"
