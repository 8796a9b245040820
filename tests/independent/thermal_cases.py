#!/usr/bin/env python3
"""`imubench thermal fit` on the independent writer's thermal sets (write_thermal.py: a
two-axis table with 20-60 arcsec on every geometric term, cubic biases, linear scales, bias
hysteresis), judged against the writer's truth:
  - the continuous ramp (10 -> 40 -> 10 degC) and the soak points (-40..+60 degC, 30 degC held
    out) fitted with exit 0; soak points on a three-axis table too (-40..+60 degC);
  - temperature coefficients within 5 %: every coefficient's change over the fitted range
    (c(T) - c(t_ref), the largest error over the range against the largest true change) for
    each bias and scale; the bias dT/dt terms (ramp); the soak set also per polynomial term
    (bias c1, c2, c3, scale c1);
  - table errors within 3 arcsec (those the motion determines: base tilt, with the two-axis
    outer encoder zero in its x component, and the nonorthogonality, with the three-axis middle
    encoder zero in middle_x); mounting and the encoder zeros reported held (observable false);
  - soak: at the held-out temperature the static holds' residual against the fit (its
    coefficients at the hold's temperature, its table errors through the chain) <= 1.2 x the
    noise floor (each hold's standard error from its own sample scatter), per triad;
  - the same fits with the table errors forced to zero (--table-errors of a zero table) are
    refused: exit 3, no file written, the findings and the `imubench explain` hint printed.
Usage: thermal_cases.py IMUBENCH --work DIR
"""
import argparse
import glob
import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import write_recording as wr  # noqa: E402
import write_thermal as wt  # noqa: E402

ARCSEC = wr.ARCSEC
FAILS = []


def check(ok, what):
    print(("ok      " if ok else "FAILED  ") + what)
    if not ok:
        FAILS.append(what)


def value(p, dT, Tdot=0.0):
    return sum(c * dT**k for k, c in enumerate(p["poly"])) + p.get("dTdt", 0.0) * Tdot


def coefficients(tr):
    """(name, P) of every scale and bias of an imubench-thermal/1 triad section."""
    for key in ("scale", "bias"):
        for i, p in enumerate(tr[key]):
            yield "%s.%s" % (key, "xyz"[i]), p


def check_changes(fit, truth, lo, hi):
    """Each bias and scale: fit change over [lo, hi] against the truth's, 5 %."""
    T = np.linspace(lo, hi, 41) - truth["t_ref_c"]
    for triad in ("accel", "gyro"):
        for (name, pt), (_, pf) in zip(coefficients(truth[triad]), coefficients(fit[triad])):
            true = np.array([value(pt, d) - value(pt, 0.0) for d in T])
            got = np.array([value(pf, d) - value(pf, 0.0) for d in T])
            err = np.max(np.abs(got - true)) / np.max(np.abs(true))
            check(err <= 0.05, "%s.%s change over %g..%g degC: error %.2f %% of the true change"
                  % (triad, name, lo, hi, 100 * err))


def check_terms(fit, truth, terms):
    """Polynomial terms (key, k) and "dTdt" of every axis within 5 % of the truth."""
    for triad in ("accel", "gyro"):
        for key, k in terms:
            for i in range(3):
                pt, pf = truth[triad][key][i], fit[triad][key][i]
                if k == "dTdt":
                    t, f = pt.get("dTdt", 0.0), pf.get("dTdt", 0.0)
                else:
                    t = pt["poly"][k]
                    f = pf["poly"][k] if len(pf["poly"]) > k else 0.0
                err = abs(f - t) / abs(t)
                check(err <= 0.05, "%s.%s.%s %s: %.4g vs true %.4g (%.2f %%)"
                      % (triad, key, "xyz"[i], "dT/dt" if k == "dTdt" else "c%d" % k, f, t,
                         100 * err))


def check_table(fit, kind):
    """Observable table errors within 3 arcsec: two-axis base tilt (x holds the outer encoder
    zero) and nonorthogonality; three-axis base tilt and nonorthogonality (middle_x holds the
    middle encoder zero)."""
    e = wt.table_errors(kind)
    check("table" in fit, "the thermal file carries the fitted table errors")
    tab = fit.get("table")
    if tab is None:
        return
    if kind == "two-axis":
        expect = {("base_tilt", 0): e["theta"][0] + e["zero"][0], ("base_tilt", 1): e["theta"][1],
                  ("nonorthogonality", 0): e["nu"][0]}
    else:
        expect = {("base_tilt", 0): e["theta"][0], ("base_tilt", 1): e["theta"][1],
                  ("nonorthogonality", 0): e["nu"][0] + e["zero"][1],
                  ("nonorthogonality", 1): e["nu"][1], ("nonorthogonality", 2): e["nu"][2]}
    for (key, i), t in expect.items():
        got = tab[key][i]
        check(abs(got - t) <= 3 * ARCSEC, "table.%s[%d]: %.2f arcsec vs %.2f (sigma %.2f)"
              % (key, i, got / ARCSEC, t / ARCSEC, tab["sigma"][key][i] / ARCSEC))
    obs = tab.get("observable", {})
    check(obs.get("mounting") in (False, [False, False]) and "encoder_zero" in obs,
          "mounting and encoder zeros reported held: %s" % json.dumps(obs))


def run(args, what):
    p = subprocess.run(args, capture_output=True, text=True)
    print("$ " + " ".join(args[1:]) + "  -> exit %d" % p.returncode)
    return p


def fit_and_judge(bin_, work, name, dirs, truth, lo, hi, terms, kind="two-axis"):
    out = os.path.join(work, name + "_comp.json")
    p = run([bin_, "thermal", "fit", *dirs, "--out", out], name)
    check(p.returncode == 0, "%s: thermal fit exit 0 (got %d)%s" % (
        name, p.returncode, "" if p.returncode == 0 else "\n" + p.stdout + p.stderr))
    if p.returncode != 0:
        return None
    print(p.stdout)
    fit = json.load(open(out))
    check_changes(fit, truth, lo, hi)
    check_terms(fit, truth, terms)
    check_table(fit, kind)
    # forced to zero: refused
    zero = os.path.join(work, "zero_table_%s.json" % kind)
    n = 1 if kind == "two-axis" else 3
    json.dump({"table": {"base_tilt": [0, 0], "nonorthogonality": [0] * n, "mounting": [0, 0],
                         "encoder_zero": [0] * (2 if n == 1 else 3)}}, open(zero, "w"))
    out0 = os.path.join(work, name + "_zero_comp.json")
    p = run([bin_, "thermal", "fit", *dirs, "--table-errors", zero, "--out", out0], name)
    check(p.returncode == 3, "%s, table forced to zero: exit 3 (got %d)" % (name, p.returncode))
    check(not os.path.exists(out0), "%s, table forced to zero: no file written" % name)
    check("imubench explain" in p.stderr and "finding:" in p.stderr,
          "%s, table forced to zero: findings and the explain hint printed" % name)
    print(p.stderr)
    return fit


def hold_means(rec):
    """Static holds of a recording: (T, angles deg, mean rates (2,3), standard errors (2,3))."""
    imu = np.loadtxt(os.path.join(rec, "imu.csv"), delimiter=",", skiprows=1)
    tab = np.loadtxt(os.path.join(rec, "table.csv"), delimiter=",", skiprows=1)
    dt = imu[1, 0] - imu[0, 0]
    out = []
    for line in open(os.path.join(rec, "segments.csv")).read().split("\n")[1:]:
        if ",static,hold-" not in line:
            continue
        t0, t1 = (float(v) for v in line.split(",")[:2])
        a, b = t0 + 0.5, t1 - 0.5
        sel = (imu[:, 0] - dt >= a) & (imu[:, 0] <= b)
        rates = imu[sel, 1:7] / dt
        ang = tab[(tab[:, 0] >= a) & (tab[:, 0] <= b), 1:3].mean(axis=0)
        se = rates.std(axis=0, ddof=1) / np.sqrt(sel.sum())
        out.append((imu[sel, 7].mean(), ang, rates.mean(axis=0), se))
    return out


def triad_reading(fit_triad, dT, inp):
    s, b, M = wt.triad_at(fit_triad, np.array([dT]), np.array([0.0]))
    return s[0] * (M[0] @ inp - b[0])


def check_held_out(fit, rec):
    """Residual of the held-out soak's holds against the fit <= 1.2 x the noise floor."""
    meta = json.load(open(os.path.join(rec, "meta.json")))
    lat, hgt = meta["site"]["latitude_deg"] * wr.DEG, meta["site"]["height_m"]
    g = wr.normal_gravity(lat, hgt)
    w_ie = wr.EARTH_RATE * np.array([0.0, np.cos(lat), np.sin(lat)])
    t = fit["table"]
    table = wr.Table("two-axis", 90.0, theta=t["base_tilt"], nu=t["nonorthogonality"],
                     mu=t["mounting"], zero=list(t["encoder_zero"]) + [0.0])
    z = {"gyro": [], "accel": []}
    for T, ang, mean, se in hold_means(rec):
        C_LB, _ = table.kinematics(ang[None, :] * wr.DEG, np.zeros((1, 2)))
        C_BL = C_LB[0].T
        dT = T - fit["t_ref_c"]
        z["gyro"] += list((mean[:3] - triad_reading(fit["gyro"], dT, C_BL @ w_ie)) / se[:3])
        z["accel"] += list((mean[3:] - triad_reading(fit["accel"], dT, C_BL @ [0, 0, g])) / se[3:])
    ref = held_out_truth_rms(rec, g, w_ie)
    for k, v in z.items():
        rms = float(np.sqrt(np.mean(np.square(v))))
        check(rms <= 1.2, "held-out %s: %s residual RMS %.2f x the noise floor (%d holds; the "
              "truth's own: %.2f)" % (os.path.basename(rec), k, rms, len(v) // 3, ref[k]))


def held_out_truth_rms(rec, g, w_ie):
    """The same statistic with the writer's truth (coefficients and table): the data's own."""
    truth = json.load(open(os.path.join(rec, "thermal_truth.json")))
    table = wr.Table("two-axis", 90.0, **wt.table_errors())
    z = {"gyro": [], "accel": []}
    for T, ang, mean, se in hold_means(rec):
        C_BL = table.kinematics(ang[None, :] * wr.DEG, np.zeros((1, 2)))[0][0].T
        dT = T - truth["t_ref_c"]
        z["gyro"] += list((mean[:3] - triad_reading(truth["gyro"], dT, C_BL @ w_ie)) / se[:3])
        z["accel"] += list((mean[3:] - triad_reading(truth["accel"], dT, C_BL @ [0, 0, g])) / se[3:])
    return {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in z.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("imubench")
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    truth = wt.thermal_truth(np.random.default_rng(5))
    # The ramp: 10 -> 40 -> 10 degC, heating and cooling.
    wt.write_set(a.work, "ramp")
    fit_and_judge(a.imubench, a.work, "ramp", [os.path.join(a.work, "ramp")], truth, 10.0,
                  40.0, [("scale", 1), ("bias", 1), ("bias", "dTdt")])
    # Soak points -40..60 degC, 30 held out.
    wt.write_set(a.work, "soak")
    soaks = sorted(d for d in glob.glob(os.path.join(a.work, "soak_*")) if os.path.isdir(d))
    fit = fit_and_judge(a.imubench, a.work, "soak", soaks, truth, -40.0, 60.0,
                        [("scale", 1), ("bias", 1), ("bias", 2), ("bias", 3)])
    if fit is not None and "table" in fit:
        check_held_out(fit, os.path.join(a.work, "heldout_%g" % wt.HELD_OUT))
    # A three-axis table: soak points, every geometric term 20-60 arcsec.
    three = []
    for k, sp in enumerate([-40.0, -20.0, 20.0, 40.0, 60.0]):
        three.append(os.path.join(a.work, "three_soak_%g" % sp))
        wt.write_thermal_case(three[-1], "three", wt.soak_temperature(sp), 1.0, truth,
                              seed=61 + k, kind="three-axis")
    fit_and_judge(a.imubench, a.work, "three", three, truth, -40.0, 60.0,
                  [("scale", 1), ("bias", 1)], kind="three-axis")
    print("%d check(s) failed" % len(FAILS) if FAILS else "thermal cases as expected")
    return 1 if FAILS else 0


if __name__ == "__main__":
    sys.exit(main())
