#!/usr/bin/env python3
"""Runs `imubench calibrate` on the independent writer's recordings (write_recording.py) and
judges every outcome: either the calibration's tolerances with exit 0, or a refusal with a
non-zero exit -- never exit 0 with a wrong answer. Prints a table of cases and outcomes.

Judged on frame-independent quantities only (the methods refer their coefficients to
different frames: nominal table, gyro-referenced platform):
  scales                                  10 ppm
  each triad's symmetric misalignment     3 arcsec  (M + M^T: nonorthogonality of the triad)
  gyro-minus-accel antisymmetric part     3 arcsec  (the triads' relative orientation)
  biases                                  2 sigma (a 95 % statement: the case is wrong when a
                                          bias lies beyond 3 sigma, or two of the six beyond 2);
                                          sigma floored at 0.5 ug / 0.0005 deg/h (noise-free)
Usage: run_cases.py IMUBENCH [--work DIR] [--cases a,b] [--table FILE]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import write_recording as wr  # noqa: E402

ARCSEC = wr.ARCSEC
UG = 9.80665e-6
DEG_H = np.pi / 180.0 / 3600.0

# (case, calibrate arguments, expectation): "accept" must meet the tolerances with exit 0,
# "refuse" must exit non-zero, "either" may do either (never exit 0 wrong).
RUNS = [
    ("two_100hz_settle_hold", [], "accept"),
    ("two_100hz_settle_hold", ["--method", "direct"], "either"),
    ("two_100hz_settle_hold", ["--method", "indirect"], "either"),
    ("two_100hz_settle_hold", ["--method", "direct", "--table-errors", "{rec}/truth.json"], "accept"),
    ("two_tilt_1deg", ["--method", "direct", "--table-errors", "{rec}/truth.json"], "accept"),
    ("two_400hz_hold", [], "accept"),
    ("two_derived_segments", [], "accept"),
    ("two_noise_free", [], "accept"),
    ("two_quantised", [], "either"),
    ("two_tilt_1deg", [], "either"),
    ("two_heading_91", [], "accept"),
    ("two_quarter_89.99999985", [], "accept"),
    ("two_single_orientation", [], "refuse"),
    ("two_swapped_gyro_xy", [], "refuse"),
    ("two_swapped_accel_xz", [], "refuse"),
    ("three_100hz_settle_hold", [], "accept"),
    ("three_100hz_settle_hold", ["--method", "direct"], "either"),
    ("three_derived_segments", [], "accept"),
    ("three_outer_fixed", [], "either"),
]


def matrix(mis):
    return np.array([[1, mis["xy"], -mis["xz"]], [-mis["yx"], 1, mis["yz"]], [mis["zx"], -mis["zy"], 1]])


def judge(est, truth):
    """(ok, worst-error text) on the frame-independent quantities."""
    bad = []
    worst = {}
    n2 = 0
    parts = {}
    for triad in ("accel", "gyro"):
        e, t = est[triad], truth[triad]
        ds = (np.array(e["scale"]) - np.array(t["scale"])) * 1e6
        worst[triad + " scale ppm"] = np.max(np.abs(ds))
        if np.max(np.abs(ds)) > 10.0:
            bad.append("%s scale %+.1f ppm" % (triad, ds[np.argmax(np.abs(ds))]))
        Ne, Nt = matrix(e["misalignment"]) - np.eye(3), matrix(t["misalignment"]) - np.eye(3)
        sym = ((Ne + Ne.T) - (Nt + Nt.T)) / 2 / ARCSEC
        worst[triad + " sym arcsec"] = np.max(np.abs(sym))
        if np.max(np.abs(sym)) > 3.0:
            bad.append("%s nonorthogonality %.1f arcsec" % (triad, np.max(np.abs(sym))))
        parts[triad] = ((Ne - Ne.T) - (Nt - Nt.T)) / 2
        unit = UG if triad == "accel" else DEG_H
        floor = 0.5 * unit if triad == "accel" else 0.0005 * unit
        sig = np.maximum(np.array(e.get("sigma", {}).get("bias", [0, 0, 0]), float), floor)
        z = np.abs(np.array(e["bias"]) - np.array(t["bias"])) / sig
        worst[triad + " bias z"] = np.max(z)
        n2 += int(np.sum(z > 2.0))
        if np.max(z) > 3.0:
            bad.append("%s bias %.1f sigma" % (triad, np.max(z)))
    rel = (parts["gyro"] - parts["accel"]) / ARCSEC
    worst["relative arcsec"] = np.max(np.abs(rel))
    if np.max(np.abs(rel)) > 3.0:
        bad.append("gyro-accel relative misalignment %.1f arcsec" % np.max(np.abs(rel)))
    if n2 > 1:
        bad.append("%d biases beyond 2 sigma" % n2)
    text = "scale %.2g/%.2g ppm, nonorth %.2g/%.2g\", rel %.2g\", bias z %.2g/%.2g" % (
        worst["accel scale ppm"], worst["gyro scale ppm"], worst["accel sym arcsec"],
        worst["gyro sym arcsec"], worst["relative arcsec"], worst["accel bias z"],
        worst["gyro bias z"])
    return not bad, "; ".join(bad) if bad else text


def last_line(text):
    """The refusal's reason: the line of the error message (imubench: ...)."""
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    main = [ln for ln in lines if ln.startswith("imubench:")]
    return (main or lines or [""])[0][:160]


def run_one(imubench, rec, args, work):
    out = os.path.join(work, "coef-%d.json" % abs(hash((rec, tuple(args)))))
    if os.path.exists(out):
        os.remove(out)
    t = time.time()
    p = subprocess.run([imubench, "calibrate", rec, "--out", out] + args, capture_output=True,
                       text=True, timeout=900)
    return p, out, time.time() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("imubench")
    ap.add_argument("--work", help="keep the recordings here (default: a temporary directory)")
    ap.add_argument("--cases", help="comma-separated case names (default: all)")
    ap.add_argument("--table", help="also write the outcome table (Markdown) to this file")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="imubench-independent-")
    cases = wr.make_cases()
    wanted = set(a.cases.split(",")) if a.cases else None
    rows = []
    failures = 0
    written = {}
    for name, args, expect in RUNS:
        if wanted and name not in wanted:
            continue
        rec = os.path.join(work, name)
        if name not in written:
            written[name] = wr.write_case(rec, cases[name])
        truth = written[name]
        args = [x.replace("{rec}", rec) for x in args]
        p, out, secs = run_one(a.imubench, rec, args, work)
        cmd = "calibrate" + ("" if not args else " " + " ".join(args).replace(rec + "/", ""))
        if p.returncode == 0:
            est = json.load(open(out))
            ok, text = judge(est, truth)
            outcome = "accurate" if ok else "WRONG (exit 0)"
            passed = ok and expect != "refuse"
        else:
            outcome = "refused (exit %d)" % p.returncode
            text = last_line(p.stderr.replace(rec, name))
            passed = expect != "accept"
        failures += 0 if passed else 1
        rows.append((name, cmd, expect, outcome, "ok" if passed else "FAIL", "%.0f" % secs, text))
        print("%-26s %-28s %-7s %-18s %-4s %4ss  %s" % rows[-1], flush=True)
        if not passed:
            print("---- stdout\n" + p.stdout[-3000:] + "\n---- stderr\n" + p.stderr[-3000:])
    if a.table:
        with open(a.table, "w") as f:
            f.write("| recording | command | expected | outcome | verdict | s | detail |\n")
            f.write("|---|---|---|---|---|---|---|\n")
            for r in rows:
                f.write("| " + " | ".join(x.replace("|", "/") for x in r) + " |\n")
    print("%d of %d runs as expected" % (len(rows) - failures, len(rows)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
