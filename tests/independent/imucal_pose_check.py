#!/usr/bin/env python3
"""imubench explain's unexplained pose on imucal's real Ferraris session, against an
independent analysis (issue 32 item 5: cli.explain_real_imucal no longer pins explain's words).

The independent analysis shares nothing with imubench (numpy only; imubench is run as a
program and its JSON report read):
  - holds: samples where a centred 0.5 s window of both the gyro and the accelerometer is
    quiet (largest per-axis standard deviation below 2.5x its median: the session is mostly at
    rest), 0.5 s trimmed off each end, at least 1.5 s left; t = n_samples / 102.4 Hz;
  - a hold's own noise (sigma of its mean, per channel): the accelerometer drifts inside a
    hold, so the larger of the pooled half-hold scatter ((first half's mean - second half's)
    / 2 over all holds: a level that does not average down) and that scatter read as white
    noise (falling as 1 / sqrt(duration), which is also each mean's weight in the fits);
  - the standard static model f = C (a - b), C diagonal (scale and bias), |f| = g = 9.81 m/s^2
    (imucal's value; another g is a common scale and leaves the misfits in readings as they
    are), fitted over the holds' means by Levenberg-Marquardt on |f| - g, each mean weighted
    by its samples (white part: the usual least squares of means); a hold's misfit in readings
    is its mean minus the model's nearest point (|f| - g carried back along the gradient).
Checked:
  1. the hold with the largest accel.x misfit in sigmas of its own noise is beyond 5 sigma
     and on the x-up face, every hold off the x-up face is within 3 sigma, and the x-up face
     was held at two levels (its holds before and after the session's middle) that differ on
     accel.x by more than 5 sigma while the attitude (their y and z readings) accounts for
     less than a tenth of it;
  2. no static term removes it: misalignment (C lower triangular, 3 terms) and a g-dependent
     (quadratic) scale q (a - b)^2 (3 terms), each fitted over all holds within datasheet
     sizes (priors 0.02 rad, 1e-3 per m/s^2), leave a hold beyond 3 sigma and the level
     difference beyond 5 sigma (free, they need shears of 13-24 deg or biases of 2-3 m/s^2:
     printed); a bias linear in time (3 terms, no static model has it) brings every hold
     within 3 sigma: the misfit is a change with time;
  3. imubench's report: its unexplained windows are all on accel.x and overlap only holds of
     the outlier's x-up level, one covers the outlier, its mean there is the independent
     misfit within 1 mm/s^2 (about one sigma of a 3.4 s hold's mean here) and lies between
     zero and the level difference (where any weighted fit puts it), every accepted effect
     is a static term tested in 2 or one that does not act on the accelerometer, and that
     window's reason names a change with time at one attitude against a span that overlaps a
     hold of the other x-up level (what 2 found: the same face reads differently later).
Which level a fit calls off is its weighting's choice: weighted by each hold's own noise
instead of its samples the early level is the larger misfit (printed as a note; the checks
use the samples' weighting, which imubench's fit of equal-length bins has too).
Two negative controls must fail the same comparison (the check can fail): the outlier and
its misfit taken from the other x-up level (the expectation transposed), and the analysis of
the recording with the outlier's level of accel.x moved onto the other one (nothing to flag).
Exit 0 when all hold, printing "imucal pose check: as the independent analysis".
"""
import argparse
import json
import os
import re
import subprocess
import sys

import numpy as np

RATE_HZ = 102.4  # imucal's example session (its examples/basic_ferraris.py)
G = 9.81
HEADER = "n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z"
MISFIT_TOL = 1.0e-3  # m/s^2, imubench's mean against the independent misfit


def read_session(path):
    """t (s), accelerometer (m/s^2) and gyro (deg/s) of imucal's CSV."""
    with open(path) as f:
        head = f.readline().strip()
    if head != HEADER:
        sys.exit("%s:1: header %r, expected %r" % (path, head, HEADER))
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    if not np.all(np.diff(d[:, 0]) == 1):
        sys.exit("%s: n_samples is not consecutive" % path)
    return d[:, 0] / RATE_HZ, d[:, 4:7], d[:, 1:4]


def moving_spread(x, win):
    """Largest per-axis standard deviation over a centred window of win samples."""
    n = len(x)
    c1 = np.vstack([np.zeros(3), np.cumsum(x, axis=0)])
    c2 = np.vstack([np.zeros(3), np.cumsum(x * x, axis=0)])
    lo = np.clip(np.arange(n) - win // 2, 0, n)
    hi = np.clip(np.arange(n) + win // 2 + 1, 0, n)
    cnt = (hi - lo)[:, None]
    m = (c1[hi] - c1[lo]) / cnt
    return np.sqrt(np.maximum((c2[hi] - c2[lo]) / cnt - m * m, 0.0)).max(axis=1)


def find_holds(acc, gyr):
    """Index ranges [i0, i1) at rest (gyro and accelerometer quiet), trimmed."""
    win, trim, shortest = int(0.5 * RATE_HZ), int(0.5 * RATE_HZ), int(1.5 * RATE_HZ)
    sg, sa = moving_spread(gyr, win), moving_spread(acc, win)
    still = (sg < 2.5 * np.median(sg)) & (sa < 2.5 * np.median(sa))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    holds = []
    for i, j in zip(edges[0::2], edges[1::2]):
        if j - i - 2 * trim >= shortest:
            holds.append((i + trim, j - trim))
    return holds


def hold_stats(t, acc, holds):
    """Means, mid times, durations and sigmas of the means (see the module text)."""
    means = np.array([acc[i:j].mean(axis=0) for i, j in holds])
    mids = np.array([0.5 * (t[i] + t[j - 1]) for i, j in holds])
    dur = np.array([(j - i) / RATE_HZ for i, j in holds])
    half = np.array([(acc[i:i + (j - i) // 2].mean(axis=0) -
                      acc[i + (j - i) // 2:i + 2 * ((j - i) // 2)].mean(axis=0)) / 2
                     for i, j in holds])
    flat = np.sqrt((half ** 2).mean(axis=0))
    white = np.sqrt((half ** 2 * dur[:, None]).mean(axis=0))
    weight = white[None, :] / np.sqrt(dur[:, None])  # read as white: the samples weigh
    sigma = np.maximum(flat[None, :], weight)
    return means, mids, dur, sigma, weight


# The static model and its extensions: f = C (a - b - d (t - t_mid)) + q * (a - b)^2.
# Parameters: b (3), diagonal of C (3), then per kind: "misalignment" C's lower triangle
# (3), "quadratic" q (3), "time" d (3).
def unpack(p, kind):
    b, C = p[:3], np.diag(p[3:6])
    q, d = np.zeros(3), np.zeros(3)
    if kind == "misalignment":
        C[1, 0], C[2, 0], C[2, 1] = p[6:9]
    elif kind == "quadratic":
        q = p[6:9]
    elif kind == "time":
        d = p[6:9]
    return b, C, q, d


def magnitude(p, kind, A, tm):
    """|f| - g per hold and the gradient of |f| with respect to the readings."""
    b, C, q, d = unpack(p, kind)
    x = A - b - np.outer(tm, d)
    f = x @ C.T + q * (A - b) ** 2
    nf = np.linalg.norm(f, axis=1)
    u = f / nf[:, None]
    J = u @ C + u * 2.0 * q * (A - b)
    return nf - G, J


# Datasheet sizes of the static terms for a consumer MEMS accelerometer (the fits with the
# terms bounded carry them as priors): cross-axis sensitivity 1-2 % (0.02 rad), nonlinearity
# about 1 % of reading per g (1e-3 per m/s^2). The time term has no prior.
PRIOR = {"misalignment": 0.02, "quadratic": 1.0e-3}


def weighted_chi(p, kind, A, W, tm, prior=None):
    """Magnitude residuals over their sigmas (W: per-channel sigmas of the means), then the
    extended terms over their prior when given."""
    e, J = magnitude(p, kind, A, tm)
    r = e / np.sqrt(((J * W) ** 2).sum(axis=1))
    return r if prior is None else np.concatenate([r, p[6:9] / prior])


def fit(A, W, tm, kind, start=None, prior=None):
    """Levenberg-Marquardt (numerical Jacobian) of the magnitude residuals weighted by W;
    the extended kinds start from the static model's solution (start) with their terms 0."""
    p = np.concatenate([np.zeros(3), np.ones(3)]) if start is None else \
        np.concatenate([start[:6], np.zeros(3)])
    lam = 1e-3

    def chi(q):
        return weighted_chi(q, kind, A, W, tm, prior)

    for _ in range(200):
        r = chi(p)
        Jp = np.empty((len(r), len(p)))
        for k in range(len(p)):
            dp = np.zeros(len(p))
            dp[k] = 1e-7 * max(1.0, abs(p[k]))
            Jp[:, k] = (chi(p + dp) - r) / dp[k]
        H = Jp.T @ Jp
        step = np.linalg.solve(H + lam * np.diag(np.diag(H)), -Jp.T @ r)
        if (chi(p + step) ** 2).sum() < (r ** 2).sum():
            p, lam = p + step, lam * 0.3
            if np.abs(step).max() < 1e-12:
                break
        else:
            lam *= 10.0
            if lam > 1e12:
                break
    return p


def misfits(p, kind, A, W, Sd, tm):
    """Per hold: the misfit in readings (measured - the model's nearest point, in the
    metric of W) and the magnitude residual in sigmas of the hold's own noise Sd."""
    e, J = magnitude(p, kind, A, tm)
    mis = (W ** 2 * J) * (e / ((J * W) ** 2).sum(axis=1))[:, None]
    return mis, e / np.sqrt(((J * Sd) ** 2).sum(axis=1))


def x_up(A):
    """Holds whose gravity direction is within 10 deg of +x."""
    return A[:, 0] / np.linalg.norm(A, axis=1) > np.cos(np.radians(10.0))


def level_masks(A, mids, k, t):
    """The x-up holds on the outlier k's side of the session's middle, and the others."""
    up = x_up(A)
    late = mids > 0.5 * (t[0] + t[-1])
    return up & (late == late[k]), up & (late != late[k])


def analyse(t, acc, gyr):
    """The independent finding: holds, fits, the outlier hold and the x-up face's levels.
    The fits weigh each hold's mean by its samples (W); z is against the hold's own noise
    (Sd); "drift-weighted" is the static model weighted by Sd instead (for the note)."""
    holds = find_holds(acc, gyr)
    A, mids, dur, Sd, W = hold_stats(t, acc, holds)
    tm = mids - 0.5 * (t[0] + t[-1])
    p0 = fit(A, W, tm, "scale")
    fits, params = {"scale": misfits(p0, "scale", A, W, Sd, tm)}, {}
    for kind in ("misalignment", "quadratic", "time"):
        params[kind] = fit(A, W, tm, kind, p0, PRIOR.get(kind))
        fits[kind] = misfits(params[kind], kind, A, W, Sd, tm)
    for kind in PRIOR:  # the same terms free: the sizes they would need
        params[kind + " free"] = fit(A, W, tm, kind, p0)
        fits[kind + " free"] = misfits(params[kind + " free"], kind, A, W, Sd, tm)
    fits["drift-weighted"] = misfits(fit(A, Sd, tm, "scale"), "scale", A, Sd, Sd, tm)
    k = int(np.argmax(np.abs(fits["scale"][0][:, 0]) / Sd[:, 0]))
    level, other = level_masks(A, mids, k, t)
    w = 1.0 / Sd[:, 0] ** 2

    def wmean(x, m):
        return float(np.sum(w[m] * x[m]) / np.sum(w[m])) if m.any() else np.nan

    delta = wmean(A[:, 0], level) - wmean(A[:, 0], other)
    delta_sigma = float(np.hypot(*[1.0 / np.sqrt(np.sum(w[m])) if m.any() else np.nan
                                   for m in (level, other)]))
    # What the fits leave of the level difference (a term that modelled it would take it).
    left = {kind: wmean(f[0][:, 0], level) - wmean(f[0][:, 0], other) for kind, f in fits.items()}
    # The change of the x reading the attitude change between the levels implies (|a| fixed):
    # -(y dy + z dz) / x from the levels' y and z readings.
    att = np.nan
    if level.any() and other.any():
        yz_l, yz_o = A[level, 1:3].mean(axis=0), A[other, 1:3].mean(axis=0)
        att = -float(0.5 * (yz_l + yz_o) @ (yz_l - yz_o)) / A[k, 0]
    return {"holds": [(t[i], t[j - 1]) for i, j in holds], "A": A, "Sd": Sd, "W": W,
            "fits": fits, "outlier": k, "level": level, "other": other, "delta": delta,
            "delta_sigma": delta_sigma, "left": left, "attitude": att, "up": x_up(A),
            "params": params}


def zx(fd, kind="scale"):
    """accel.x misfits of a fit in sigmas of each hold's own noise."""
    return fd["fits"][kind][0][:, 0] / fd["Sd"][:, 0]


def independent_failures(fd):
    """What the independent analysis must establish before imubench is compared with it."""
    bad, k, z = [], fd["outlier"], fd["fits"]["scale"][1]
    if abs(zx(fd)[k]) < 5.0:
        bad.append("no hold beyond 5 sigma (largest |z| %.2f)" % abs(zx(fd)[k]))
    if not fd["up"][k]:
        bad.append("the outlier hold is not on the x-up face")
    off = ~fd["up"]
    if off.any() and np.abs(z[off]).max() >= 3.0:
        bad.append("a hold off the x-up face beyond 3 sigma")
    if not abs(fd["delta"]) >= 5.0 * fd["delta_sigma"]:
        bad.append("the x-up face's two levels within 5 sigma")
    if not abs(fd["attitude"]) < 0.1 * abs(fd["delta"]):
        bad.append("the attitude accounts for a tenth of the level difference or more")
    for kind in ("misalignment", "quadratic"):
        if np.abs(fd["fits"][kind][1]).max() < 3.0 or \
                not abs(fd["left"][kind]) >= 5.0 * fd["delta_sigma"]:
            bad.append("the %s term removes the outlier" % kind)
    if np.abs(fd["fits"]["time"][1]).max() >= 3.0:
        bad.append("a bias linear in time does not bring every hold within 3 sigma")
    return bad


def overlaps(w, span):
    return min(w["t1"], span[1]) > max(w["t0"], span[0])


# Accepted effects the independent analysis tested as static accelerometer terms (the
# misalignment fit covers the table's angle terms, gravity_error is the common scale the
# scale fit absorbs), and effects that do not act on the accelerometer.
STATIC_TESTED = {"accel_k2", "nonorthogonality", "mounting", "base_tilt", "gravity_error"}
GYRO_ONLY = {"gyro_g_sensitivity", "scale_asymmetry", "latitude_error"}


def time_change_named(window, other_level):
    """The window's reason names a change with time at one attitude, compared with a span
    that overlaps a hold of the other level; [] or the disagreement."""
    reason = window.get("reason", "")
    m = re.search(r"held at ([0-9.]+)-([0-9.]+) s reads .* changes with time at one attitude",
                  reason)
    if not m:
        return ["window %.1f-%.1f s names no change with time at one attitude: %s" %
                (window["t0"], window["t1"], reason)]
    span = {"t0": float(m.group(1)), "t1": float(m.group(2))}
    if not any(overlaps(span, h) for h in other_level):
        return ["window %.1f-%.1f s compares with %.1f-%.1f s, no hold of the other level" %
                (window["t0"], window["t1"], span["t0"], span["t1"])]
    return []


def compare(fd, report):
    """imubench's report against the finding: a list of disagreements (empty: agreement)."""
    k, holds = fd["outlier"], fd["holds"]
    windows = report.get("unexplained", [])
    bad = []
    if abs(zx(fd)[k]) < 5.0:
        bad.append("imubench flags %d window(s), the independent hold %d is at %.1f sigma" %
                   (len(windows), k + 1, zx(fd)[k]))
    if not windows:
        return bad + ["imubench flags nothing, the independent analysis hold %d" % (k + 1)]
    level = [holds[i] for i in np.flatnonzero(fd["level"])]
    for w in windows:
        if w["channel"] != "accel.x" or not any(overlaps(w, h) for h in level) or any(
                overlaps(w, holds[i]) for i in range(len(holds)) if not fd["level"][i]):
            bad.append("window %.1f-%.1f s %s is not on hold %d's level" %
                       (w["t0"], w["t1"], w["channel"], k + 1))
    mid = 0.5 * (holds[k][0] + holds[k][1])
    cover = [w for w in windows if w["t0"] <= mid <= w["t1"]]
    if not cover:
        return bad + ["no window covers hold %d (%.1f-%.1f s)" % ((k + 1,) + holds[k])]
    mean, misfit = cover[0]["mean"], fd["fits"]["scale"][0][k, 0]
    if abs(mean - misfit) > MISFIT_TOL:
        bad.append("mean %.2f mm/s^2 against the independent %.2f (tolerance %.1f)" %
                   (1e3 * mean, 1e3 * misfit, 1e3 * MISFIT_TOL))
    if not 0.0 < mean / fd["delta"] < 1.0:
        bad.append("mean %.2f mm/s^2 not between 0 and the level difference %.2f" %
                   (1e3 * mean, 1e3 * fd["delta"]))
    bad += time_change_named(cover[0], [holds[i] for i in np.flatnonzero(fd["other"])])
    for e in report.get("accepted", []):
        if e["effect"] not in STATIC_TESTED | GYRO_ONLY:
            bad.append("accepted %s: not a term the independent analysis tested" % e["effect"])
    return bad


def transposed(fd):
    """The expectation read from the other x-up level: its largest misfit as the outlier."""
    other = np.flatnonzero(fd["other"])
    if len(other) == 0:
        return None
    mis = fd["fits"]["scale"][0][:, 0]
    t = dict(fd)
    t["outlier"] = int(other[np.argmax(np.abs(mis[other]))])
    t["level"], t["other"], t["delta"] = fd["other"], fd["level"], -fd["delta"]
    return t


def levelled(t, acc, fd):
    """The recording with the outlier's level moved onto the other one (accel.x only)."""
    spans = [fd["holds"][i] for i in np.flatnonzero(fd["level"])]
    a = acc.copy()
    sel = (t >= spans[0][0] - 1.0) & (t <= spans[-1][1] + 1.0)
    a[sel, 0] -= fd["delta"]
    return a


def term_text(p, kind):
    """The fitted extra terms (and for the free fits the bias and scale they move to)."""
    if p is None:
        return ""
    unit = {"misalignment": "rad", "quadratic": "per m/s^2", "time": "m/s^3"}[kind.split()[0]]
    out = "; terms %s %s" % (" ".join("%.3g" % v for v in p[6:9]), unit)
    if kind.endswith("free"):
        out += ", bias %s, scale %s" % (" ".join("%.3g" % v for v in p[:3]),
                                       " ".join("%.4g" % v for v in p[3:6]))
    return out


def print_finding(fd):
    mis, z, k = fd["fits"]["scale"][0][:, 0], zx(fd), fd["outlier"]
    print("independent: %d holds; static model scale + bias, g = %.2f, each hold weighted by "
          "its samples; sigma = the hold's own noise (accel.x %.2f-%.2f mm/s^2)" %
          (len(fd["holds"]), G, 1e3 * fd["Sd"][:, 0].min(), 1e3 * fd["Sd"][:, 0].max()))
    print("%4s %15s %10s %10s %8s %8s %9s" % ("hold", "span s", "accel.x", "misfit.x",
                                            "z.x", "z", "x-up"))
    for i, (t0, t1) in enumerate(fd["holds"]):
        tag = "outlier's" if fd["level"][i] else ("other" if fd["other"][i] else "")
        print("%4d %7.2f-%7.2f %10.4f %10.2f %8.2f %8.2f %9s" % (
            i + 1, t0, t1, fd["A"][i, 0], 1e3 * mis[i], z[i], fd["fits"]["scale"][1][i], tag))
    print("outlier: hold %d, accel.x %.2f mm/s^2 (%.1f sigma); the x-up face's levels differ "
          "by %.2f +- %.2f mm/s^2, the attitude accounts for %.2f" %
          (k + 1, 1e3 * mis[k], z[k], 1e3 * fd["delta"], 1e3 * fd["delta_sigma"],
           1e3 * fd["attitude"]))
    for kind in ("misalignment", "quadratic", "time", "misalignment free", "quadratic free",
                 "drift-weighted"):
        zk, mk = fd["fits"][kind][1], fd["fits"][kind][0][:, 0]
        print("  %-17s level difference left %6.2f mm/s^2; hold %d %6.2f mm/s^2; largest |z| "
              "%.2f (hold %d)%s" % (kind, 1e3 * fd["left"][kind], k + 1, 1e3 * mk[k],
                                    np.abs(zk).max(), np.argmax(np.abs(zk)) + 1,
                                    term_text(fd["params"].get(kind), kind)))
    mis_d, z_d = fd["fits"]["drift-weighted"][0][:, 0], fd["fits"]["drift-weighted"][1]
    j = int(np.argmax(np.abs(z_d)))
    print("note: which x-up level a static fit calls off is its weighting's choice: weighted by "
          "each hold's own noise instead of its samples, hold %d is the largest (%.2f mm/s^2, "
          "%.1f sigma) and hold %d %.2f mm/s^2 (%.1f sigma); the data say the x reading of the "
          "x-up face moved by %.2f mm/s^2 between its two levels (a bias linear in time fits "
          "every hold)" % (j + 1, 1e3 * mis_d[j], z_d[j], k + 1, 1e3 * mis_d[k], z_d[k],
                           1e3 * fd["delta"]))


def run_explain(imubench, session, report):
    run = subprocess.run([imubench, "explain", session, "--format", "imucal", "--json", report],
                         capture_output=True, text=True, timeout=240)
    if run.returncode != 0:
        print(run.stdout, run.stderr)
        sys.exit("FAIL: imubench explain exited %d" % run.returncode)
    with open(report) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("imubench")
    ap.add_argument("real_dir")
    ap.add_argument("--work", required=True)
    args = ap.parse_args()
    session = os.path.join(args.real_dir, "imucal_example_ferraris_session.csv")
    os.makedirs(args.work, exist_ok=True)
    t, acc, gyr = read_session(session)
    fd = analyse(t, acc, gyr)
    print_finding(fd)
    bad = ["independent: " + b for b in independent_failures(fd)]
    report = run_explain(args.imubench, session, os.path.join(args.work, "imucal_explain.json"))
    for w in report.get("unexplained", []):
        print("imubench: unexplained %.1f-%.1f s %s %.2f mm/s^2 (%.1f sigma) %s" %
              (w["t0"], w["t1"], w["channel"], 1e3 * w["mean"], w["sigma"], w["reason"]))
    print("imubench: accepted %s" % ([e["effect"] for e in report.get("accepted", [])] or "none"))
    bad += compare(fd, report)
    # The comparison can fail: against the other level's hold (transposed) and against the
    # analysis of the levelled recording (nothing to flag) it must.
    t_fd = transposed(fd)
    neg_t = compare(t_fd, report) if t_fd is not None else ["no other level"]
    neg_l = compare(analyse(t, levelled(t, acc, fd), gyr), report)
    print("control, the other level's hold %d as the outlier: %s" %
          ((t_fd["outlier"] + 1) if t_fd else 0, "; ".join(neg_t) or "AGREES (must not)"))
    print("control, the levelled recording: %s" % ("; ".join(neg_l) or "AGREES (must not)"))
    if not neg_t or not neg_l:
        bad.append("a negative control agrees with imubench")
    for b in bad:
        print("FAIL: " + b)
    print("imucal pose check: %s" % ("FAIL" if bad else "as the independent analysis"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
