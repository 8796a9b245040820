#!/bin/sh
# Issue 29 item 4: `imubench certificate RUN` writes one self-contained HTML page that headless
# Chromium renders with no network at all (in a network namespace of its own where the host
# allows one, else with every host name unresolvable and a dead proxy), every section present,
# the recording checksums those of `imubench export RUN --csv` (sha256sum), the stored verdict
# and coefficients on the page; offline (DIR --coefficients) the same page without a verdict;
# a run without coefficients gets a page that says so and exit 1.
# Chromium is a test dependency (tools/install-deps.sh: chromium-headless-shell): without it
# this test FAILS, it does not skip.
# Usage: certificate_chromium.sh IMUBENCH PLAN_DIR TRUTH [SCREENSHOT_PNG]
set -e
bin="$1"; plans="$2"; truth="$3"; shot="$4"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
db="$work/runs.db"
fail() { echo "certificate_chromium.sh: $*" >&2; exit 1; }

chrome=""
for c in chromium-headless-shell chromium chromium-browser; do
  if command -v "$c" > /dev/null 2>&1; then chrome=$(command -v "$c"); break; fi
done
[ -n "$chrome" ] || fail "no headless Chromium (chromium-headless-shell or chromium): run tools/install-deps.sh"

# No network for the browser: its own empty network namespace when allowed, else no name
# resolves and every request goes to a proxy nobody serves.
isolate=""
if unshare -n true 2> /dev/null; then isolate="unshare -n"
elif unshare -rn true 2> /dev/null; then isolate="unshare -rn"; fi
browse() {
  $isolate "$chrome" --headless --no-sandbox --disable-gpu --no-first-run \
    --proxy-server=127.0.0.1:9 --host-resolver-rules="MAP * ~NOTFOUND" "$@" 2> "$work/chrome.err"
}

"$bin" simulate "$plans/direct_two_axis.toml" --truth "$truth" --out "$work/rec" --rate 20 \
  --seed 7 --noise nav-grade > /dev/null
"$bin" import "$work/rec" --db "$db" --plan-name direct_two_axis --serial SN-CERT-7 > /dev/null
"$bin" import "$work/rec" --db "$db" --plan-name direct_two_axis --serial SN-CERT-7 > /dev/null
"$bin" calibrate 1 --db "$db" --method direct --table-errors "$truth" --store-result > /dev/null 2>&1
"$bin" calibrate 1 --db "$db" --method direct --table-errors "$truth" --out "$work/coeffs.json" > /dev/null 2>&1
"$bin" explain 1 --db "$db" --json "$work/explain.json" > /dev/null 2>&1 || true
[ -s "$work/explain.json" ] || fail "explain 1 wrote no report"
# The daemon's verdict and explain report as it stores them (daemon/run_calibration.cpp).
python3 - "$db" "$work/explain.json" "$plans/direct_two_axis.toml" <<'PY'
import json, sqlite3, sys, time
db = sqlite3.connect(sys.argv[1])
# The plan text and bench name a daemon run carries (an import stores neither).
db.execute("UPDATE runs SET plan_toml = ?, bench_name = 'virtual-bench-A' WHERE id = 1",
           (open(sys.argv[3]).read(),))
def result(run, kind, doc):
    db.execute("INSERT INTO results(run_id, imu_serial, temperature_c, kind, json, created_unix_s)"
               " VALUES (?, 'SN-CERT-7', 25.0, ?, ?, ?)", (run, kind, json.dumps(doc), time.time()))
result(1, "explain", json.load(open(sys.argv[2])))
result(1, "report", {"method": "direct", "software": "imubench 0.0.9 (git 0123456789ab)"})
result(1, "verdict", {"pass": True, "rows": [{"parameter": "gyro.bias.x", "limit": 0.05,
       "unit": "deg/h", "value": 0.0012, "pass": True}]})
db.commit()
PY

"$bin" certificate 1 --db "$db" --out "$work/cert" || fail "certificate 1 failed"
page="$work/cert/certificate.html"
[ -s "$page" ] || fail "no $page"
# Self-contained: nothing that could load from anywhere.
if grep -Eiq '<script|<link|<img|<iframe|src=|href=|url\(|@import|https?:' "$page"; then
  grep -Eio '.{30}(<script|<link|<img|<iframe|src=|href=|url\(|@import|https?:).{30}' "$page" >&2
  fail "the certificate references an outside resource"
fi
browse --dump-dom "file://$page" > "$work/dom.html" || { cat "$work/chrome.err" >&2; fail "chromium failed"; }
[ -s "$work/dom.html" ] || { cat "$work/chrome.err" >&2; fail "chromium rendered nothing"; }
for id in identity recording coefficients observability table-errors envelope findings verdict software; do
  grep -q "<section id=\"$id\">" "$work/dom.html" || fail "section $id missing from the rendered page"
done
grep -q "SN-CERT-7" "$work/dom.html" || fail "IMU serial missing"
grep -q "direct_two_axis" "$work/dom.html" || fail "plan name missing"
grep -q "<b>PASS</b>" "$work/dom.html" || fail "verdict PASS missing"
grep -q "gyro.misalignment.xy" "$work/dom.html" || fail "coefficients missing"
grep -q "table.base_tilt.x" "$work/dom.html" || fail "table errors missing"
grep -q "imubench-explain\|Normalised residual RMS" "$work/dom.html" || fail "explain findings missing"
# The software that calibrated (the stored report's) and the one that wrote the page (this
# build's --version, with its commit).
grep -q "imubench 0.0.9 (git 0123456789ab)" "$work/dom.html" || fail "calibrating software missing"
grep -qF "$("$bin" --version)" "$work/dom.html" || fail "certificate software ($("$bin" --version)) missing"
# The checksums are those of the recording as `imubench export` writes it.
"$bin" export 1 --db "$db" --csv "$work/exported" > /dev/null
(cd "$work/exported" && sha256sum *) > "$work/sums.txt"
n=0
while read -r sum file; do
  grep -q "$sum" "$work/dom.html" || fail "checksum of $file ($sum) not on the page"
  n=$((n + 1))
done < "$work/sums.txt"
[ "$n" -ge 3 ] || fail "only $n recording files checksummed"
# The plan's checksum: of its text as stored (the plan file).
plan_sum=$(sha256sum < "$plans/direct_two_axis.toml" | cut -d' ' -f1)
grep -q "$plan_sum" "$work/dom.html" || fail "plan checksum ($plan_sum) not on the page"
grep -q "virtual-bench-A" "$work/dom.html" || fail "bench name missing"
if [ -n "$shot" ]; then
  browse --screenshot="$shot" --window-size=1100,2700 --hide-scrollbars "file://$page" > /dev/null \
    || fail "screenshot failed"
fi

# Offline: a recording directory and a coefficient file; no verdict, said so.
"$bin" certificate "$work/rec" --coefficients "$work/coeffs.json" --explain "$work/explain.json" \
  --out "$work/offline" > /dev/null || fail "offline certificate failed"
browse --dump-dom "file://$work/offline/certificate.html" > "$work/dom2.html"
grep -q "<b>NO VERDICT</b>" "$work/dom2.html" || fail "offline page claims a verdict"
grep -q "<section id=\"envelope\">" "$work/dom2.html" || fail "offline envelope missing"
# A run without coefficients: the page says so, exit 1.
set +e
"$bin" certificate 2 --db "$db" --out "$work/empty" > "$work/empty.out" 2>&1; code=$?
set -e
[ "$code" = 1 ] || fail "certificate of a run without coefficients: exit $code, expected 1"
grep -q "No coefficients stored" "$work/empty/certificate.html" || fail "empty page does not say so"
grep -q "certifies nothing" "$work/empty.out" || fail "no message for the empty certificate"
echo "PASS"
