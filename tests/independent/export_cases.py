#!/usr/bin/env python3
"""Independent checks of `imubench export-coeffs` (issue 29 item 3).

For each target the exported file is parsed here (round trip JSON -> target file -> numbers)
and the TARGET's own compensation formula, written from its documentation and source (no code
shared with imubench), is applied to raw readings; the result must agree with `imubench apply`
(the interchange.md sensor equation, reading = diag(s) (M u - b)) to within the terms the
target cannot carry, and exactly where it carries everything:
  PX4       accel = (raw - thermal_offset - CAL_ACC0_*OFF) .* CAL_ACC0_*SCALE,
            gyro = raw - thermal_offset - CAL_GYRO0_*OFF,
            thermal_offset = sum_k X_k dT^k, dT = clamp(T, TMIN, TMAX) - TREF
  ArduPilot v = raw - P(T - 35) + P(CALTEMP - 35), P(x) = 1e-6 (c1 x + c2 x^2 + c3 x^3),
            T, CALTEMP clamped to [TMIN, TMAX]; accel = (v - INS_ACCOFFS) .* INS_ACCSCAL,
            gyro = v - INS_GYROFFS
  OpenVINS  a_I = R_IMUtoACC^T Ta^-1 (a_m - b_a), w_I = R_IMUtoGYRO^T Tw^-1 (w_m - Tg a_I - b_g)
            (rpng: Tw, Ta upper triangular; Kalibr model: lower triangular), no biases carried
  CSV       the coefficient values themselves

Usage: export_cases.py IMUBENCH --work DIR
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

MIS = ["xy", "xz", "yx", "yz", "zx", "zy"]


def mmat(m):
    return np.array([[1, m["xy"], -m["xz"]], [-m["yx"], 1, m["yz"]], [m["zx"], -m["zy"], 1]])


def run(bin_, args):
    p = subprocess.run([bin_] + args, capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout + p.stderr


def coeffs(rng, mis=True, gyro_scale=True):
    def triad(sc, bi, mi):
        return {"scale": list(1 + sc * rng.uniform(-1, 1, 3)) if sc else [1.0, 1.0, 1.0],
                "bias": list(bi * rng.uniform(-1, 1, 3)),
                "misalignment": {k: (mi * rng.uniform(-1, 1) if mis else 0.0) for k in MIS}}
    return {"accel": triad(2e-3, 0.05, 1e-3),
            "gyro": triad(3e-3 if gyro_scale else 0.0, 2e-3, 1e-3)}


def write_recording(d, c, rng, temps):
    """Raw readings of random inputs, with temperatures, static holds in segments.csv."""
    os.makedirs(d, exist_ok=True)
    n, dt = len(temps), 0.01
    t = np.arange(1, n + 1) * dt
    u_a = rng.uniform(-12, 12, (n, 3))
    u_w = rng.uniform(-3, 3, (n, 3))
    hold = np.zeros(n, bool)
    hold[: n // 2] = True  # first half static (for the noise)
    u_a[hold] = [0.3, -0.2, 9.8]
    u_w[hold] = [0.0, 0.0, 0.0]
    out = []
    for tri, u in (("accel", u_a), ("gyro", u_w)):
        s = np.array(c[tri]["scale"])
        b = np.array(c[tri]["bias"])
        r = (mmat(c[tri]["misalignment"]) @ u.T).T - b
        r = s * r + (0.002 if tri == "accel" else 1e-4) * rng.standard_normal((n, 3))
        out.append(r)
    ra, rw = out
    json.dump({"format": "imubench-csv/1", "site": {"latitude_deg": 50.0, "height_m": 0.0},
               "imu": {"serial": "X1", "rate_hz": 100.0}, "table": {"kind": "two-axis"}},
              open(os.path.join(d, "meta.json"), "w"))
    with open(os.path.join(d, "imu.csv"), "w") as f:
        f.write("t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n")
        for k in range(n):
            f.write(",".join(repr(float(x)) for x in
                             [t[k], *(rw[k] * dt), *(ra[k] * dt), temps[k]]) + "\n")
    open(os.path.join(d, "table.csv"), "w").write("t,outer,inner\n")
    open(os.path.join(d, "segments.csv"), "w").write(
        "t0,t1,kind,label\n%r,%r,static,hold\n" % (t[0], t[n // 2 - 1]))
    return t, ra, rw


def thermal_json(c, bias_polys=None, scale_polys=None):
    def tri(name):
        x = c[name]
        sc = [{"poly": (scale_polys[name][i] if scale_polys else [x["scale"][i]])} for i in range(3)]
        bi = [{"poly": (bias_polys[name][i] if bias_polys else [x["bias"][i]])} for i in range(3)]
        return {"scale": sc, "bias": bi,
                "misalignment": {k: {"poly": [x["misalignment"][k]]} for k in MIS}}
    return {"format": "imubench-thermal/1", "imu": {"serial": "X1"}, "t_ref_c": 20.0,
            "range_c": [-20.0, 50.0], "accel": tri("accel"), "gyro": tri("gyro")}


def applied(bin_, comp, rec, out):
    code, text = run(bin_, ["apply", comp, rec, "--out", out])
    if code != 0:
        raise RuntimeError(text)
    a = np.genfromtxt(os.path.join(out, "imu.csv"), delimiter=",", skip_header=1)
    dt = np.diff(np.concatenate([[a[0, 0] - (a[1, 0] - a[0, 0])], a[:, 0]]))
    return a[:, 4:7] / dt[:, None], a[:, 1:4] / dt[:, None]


def params(path):
    """PX4 QGC lines (1 1 NAME VALUE TYPE) or ArduPilot NAME,VALUE; '#' comments."""
    p = {}
    for line in open(path):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        f = line.split("\t") if "\t" in line else line.split(",")
        name, val = (f[2], f[3]) if len(f) == 5 else (f[0], f[1])
        p[name] = float(val)
    return p


def yaml_mats(path):
    """The 3x3 matrices and scalars of an OpenVINS/Kalibr chain file (block lists)."""
    mats, cur, scal = {}, None, {}
    for line in open(path):
        s = line.split("#")[0].rstrip()
        if not s.strip():
            continue
        if s.startswith("  ") and not s.startswith("    ") and s.strip().endswith(":"):
            cur = s.strip()[:-1]
            mats[cur] = []
        elif s.startswith("    - [") and cur is not None:
            mats[cur].append([float(x) for x in s.strip()[3:-1].split(",")])
        elif s.startswith("  ") and ":" in s:
            k, v = s.strip().split(":", 1)
            try:
                scal[k] = float(v)
            except ValueError:
                pass
    return {k: np.array(v) for k, v in mats.items() if len(v) == 3}, scal


def px4_apply(p, ra, rw, temp):
    off_a = np.array([p["CAL_ACC0_%sOFF" % x] for x in "XYZ"])
    sc_a = np.array([p["CAL_ACC0_%sSCALE" % x] for x in "XYZ"])
    off_g = np.array([p["CAL_GYRO0_%sOFF" % x] for x in "XYZ"])

    def th(pre):
        if p.get(pre + "_ENABLE", 0) != 1:
            return 0.0
        b = pre + "0_"
        dT = np.clip(temp, p[b + "TMIN"], p[b + "TMAX"]) - p[b + "TREF"]
        return np.stack([sum(p[b + "X%d_%d" % (k, a)] * dT ** k for k in range(4))
                         for a in range(3)], 1)
    return (ra - th("TC_A") - off_a) * sc_a, rw - th("TC_G") - off_g


def ardupilot_apply(p, ra, rw, temp):
    def tcal(kind):
        if p.get("INS_TCAL1_ENABLE", 0) != 1:
            return 0.0
        lo, hi = p["INS_TCAL1_TMIN"], p["INS_TCAL1_TMAX"]
        cal = np.clip(p["INS_%s1_CALTEMP" % ("ACC" if kind == "ACC" else "GYR")], lo, hi)
        T = np.clip(temp, lo, hi)

        def P(x):
            c = [np.array([p["INS_TCAL1_%s%d_%s" % (kind, k, a)] for a in "XYZ"]) for k in (1, 2, 3)]
            x = np.asarray(x, float)[..., None]
            return (c[0] + (c[1] + c[2] * x) * x) * x * 1e-6
        return P(T - 35.0) - P(cal - 35.0)
    va = ra - tcal("ACC")
    vg = rw - tcal("GYR")
    return ((va - np.array([p["INS_ACCOFFS_%s" % x] for x in "XYZ"]))
            * np.array([p["INS_ACCSCAL_%s" % x] for x in "XYZ"]),
            vg - np.array([p["INS_GYROFFS_%s" % x] for x in "XYZ"]))


def chain_apply(m, ra, rw, kalibr):
    tri = np.tril if kalibr else np.triu
    ok = all(np.allclose(m[k], tri(m[k]), atol=0) for k in ("Tw", "Ta"))
    a_I = (m["R_IMUtoACC"].T @ np.linalg.solve(m["Ta"], ra.T)).T
    w_I = (m["R_IMUtoGYRO"].T @ np.linalg.solve(m["Tw"], (rw - (m["Tg"] @ a_I.T).T).T)).T
    return a_I, w_I, ok


class Checks:
    def __init__(self, bin_, work):
        self.bin, self.work, self.failed, self.passed = bin_, work, [], 0

    def check(self, name, ok, detail=""):
        print(("ok    " if ok else "FAIL  ") + name + ("" if ok else ": " + detail))
        (self.failed.append(name) if not ok else None)
        self.passed += bool(ok)

    def export(self, coeffs_path, to, out, extra=()):
        code, text = run(self.bin, ["export-coeffs", coeffs_path, "--to", to, "--out", out] + list(extra))
        if code != 0:
            raise RuntimeError(to + ": " + text)
        return text


def cubic_fit_residual(s_poly, b_poly, lo=-20.0, hi=50.0, tref=20.0):
    """Max |r0 - cubic| of the zero-input reading r0(T) = -s(T) b(T) over the range."""
    T = np.linspace(lo, hi, 401)
    x = T - tref
    r0 = -np.polyval(s_poly[::-1], x) * np.polyval(b_poly[::-1], x)
    return np.abs(np.polyval(np.polyfit(x, r0, 3), x) - r0).max()


def constant_case(ch, name, c, rng, full):
    d = os.path.join(ch.work, name)
    os.makedirs(d, exist_ok=True)
    cj = os.path.join(d, "coeffs.json")
    json.dump(c, open(cj, "w"))
    temps = rng.uniform(10, 30, 4000)
    rec = os.path.join(d, "rec")
    t, ra, rw = write_recording(rec, c, rng, temps)
    comp = os.path.join(d, "comp.json")
    json.dump(thermal_json(c), open(comp, "w"))
    ua, uw = applied(ch.bin, comp, rec, os.path.join(d, "applied"))
    tol = 1e-9
    # CSV round trip
    ch.export(cj, "csv", os.path.join(d, "c.csv"))
    rows = [l.strip().split(",") for l in open(os.path.join(d, "c.csv")).readlines()[1:]]
    back = {"accel": {"scale": [0] * 3, "bias": [0] * 3, "misalignment": {}},
            "gyro": {"scale": [0] * 3, "bias": [0] * 3, "misalignment": {}}}
    for tri, co, ax, v in rows:
        if co == "misalignment":
            back[tri][co][ax] = float(v)
        else:
            back[tri][co]["XYZ".index(ax)] = float(v)
    ch.check(name + " csv: round trip of every coefficient", back == c, str(back))
    # PX4 and ArduPilot
    for to, fn in (("px4", px4_apply), ("ardupilot", ardupilot_apply)):
        f = os.path.join(d, to + ".params")
        text = ch.export(cj, to, f)
        pa, pw = fn(params(f), ra, rw, temps)
        ea, ew = np.abs(pa - ua), np.abs(pw - uw)
        if not full:
            ch.check("%s %s: target formula = imubench apply (max %.2g, %.2g)" % (name, to, ea.max(), ew.max()),
                     ea.max() < tol * 20 and ew.max() < tol, "")
        else:
            # What the target cannot carry, exactly: without M the accelerometer output is
            # diag(s)^-1 r + b = M u, the gyro (no scale either) r + diag(s) b = diag(s) M u.
            Ma = mmat(c["accel"]["misalignment"])
            Mg = np.diag(c["gyro"]["scale"]) @ mmat(c["gyro"]["misalignment"])
            pred_a = ((Ma - np.eye(3)) @ ua.T).T
            pred_w = ((Mg - np.eye(3)) @ uw.T).T
            ra_ = np.abs(pa - ua - pred_a).max()
            rw_ = np.abs(pw - uw - pred_w).max()
            ch.check("%s %s: differs from apply by exactly the dropped misalignment/gyro scale "
                     "(%.2g, %.2g)" % (name, to, ra_, rw_),
                     ra_ < tol * 20 and rw_ < tol and "misalignments" in text
                     and np.abs(pred_a).max() > 1e-3, text)
    # Kalibr and OpenVINS
    for to in ("kalibr", "openvins"):
        f = os.path.join(d, to + ".yaml")
        text = ch.export(cj, to, f, ["--recording", rec])
        m, scal = yaml_mats(f)
        a_I, w_I, tri_ok = chain_apply(m, ra, rw, to == "kalibr")
        R = m["imubench_R_BtoIMU"]
        ha = R @ (np.linalg.inv(mmat(c["accel"]["misalignment"])) @ np.array(c["accel"]["bias"]))
        hg = R @ (np.linalg.inv(mmat(c["gyro"]["misalignment"])) @ np.array(c["gyro"]["bias"]))
        # the only dropped terms are the biases: adding them back gives apply in frame I
        ea = np.abs(a_I + ha - (R @ ua.T).T).max()
        ew = np.abs(w_I + hg - (R @ uw.T).T).max()
        noise_ok = all(k in scal for k in ("accelerometer_noise_density", "gyroscope_noise_density",
                                            "accelerometer_random_walk", "gyroscope_random_walk"))
        # white noise written at 0.002 m/s^2 and 1e-4 rad/s per sample at 100 Hz:
        # density = sigma * sqrt(dt)
        dens_ok = noise_ok and abs(scal["accelerometer_noise_density"] / (0.002 * 0.1) - 1) < 0.25 \
            and abs(scal["gyroscope_noise_density"] / (1e-4 * 0.1) - 1) < 0.25
        ch.check("%s %s: target formula + dropped biases = apply (max %.2g, %.2g), triangular, "
                 "noise density in Kalibr's convention" % (name, to, ea, ew),
                 ea < tol * 20 and ew < tol and tri_ok and dens_ok and "bias" in text,
                 str(scal))


def thermal_case(ch, rng):
    d = os.path.join(ch.work, "thermal")
    os.makedirs(d, exist_ok=True)
    c = coeffs(rng, mis=False, gyro_scale=False)
    cj = os.path.join(d, "coeffs.json")
    json.dump(c, open(cj, "w"))
    bias = {tri: [[c[tri]["bias"][i], 1e-3 * rng.uniform(-1, 1), 1e-5 * rng.uniform(-1, 1),
                   2e-7 * rng.uniform(-1, 1)] for i in range(3)] for tri in ("accel", "gyro")}
    for i in range(3):
        bias["gyro"][i] = [x * 0.05 for x in bias["gyro"][i]]
    comp = os.path.join(d, "comp.json")
    json.dump(thermal_json(c, bias), open(comp, "w"))
    temps = np.linspace(-30, 60, 4000)  # beyond the range on both sides: clamped
    rec = os.path.join(d, "rec")
    t, ra, rw = write_recording(rec, c, rng, temps)
    ua, uw = applied(ch.bin, comp, rec, os.path.join(d, "applied"))
    for to, fn in (("px4", px4_apply), ("ardupilot", ardupilot_apply)):
        f = os.path.join(d, to + ".params")
        ch.export(cj, to, f, ["--thermal", comp])
        pa, pw = fn(params(f), ra, rw, temps)
        ea, ew = np.abs(pa - ua).max(), np.abs(pw - uw).max()
        ch.check("thermal %s: cubic bias over temperature = apply (max %.2g, %.2g)" % (to, ea, ew),
                 ea < 1e-7 and ew < 1e-9, "")
    # with a temperature-dependent scale the targets drop its change: bounded by it
    sc = {tri: [[c[tri]["scale"][i], 2e-5 * rng.uniform(-1, 1)] for i in range(3)]
          for tri in ("accel", "gyro")}
    comp2 = os.path.join(d, "comp2.json")
    json.dump(thermal_json(c, bias, sc), open(comp2, "w"))
    ua, uw = applied(ch.bin, comp2, rec, os.path.join(d, "applied2"))
    dT = np.clip(temps, -20, 50) - 20.0
    for to, fn in (("px4", px4_apply), ("ardupilot", ardupilot_apply)):
        f = os.path.join(d, to + "2.params")
        text = ch.export(cj, to, f, ["--thermal", comp2])
        pa, pw = fn(params(f), ra, rw, temps)
        ka = np.array([x[1] for x in sc["accel"]])
        kw = np.array([x[1] for x in sc["gyro"]])
        fit_a = np.array([cubic_fit_residual(sc["accel"][i], bias["accel"][i]) for i in range(3)])
        fit_w = np.array([cubic_fit_residual(sc["gyro"][i], bias["gyro"][i]) for i in range(3)])
        # s(T)/s_ref - 1 of the input, plus the cubic fit of the offset (2x: another grid)
        ba = np.abs(ka * dT[:, None] * ua) * 1.05 + 2 * fit_a + 1e-9
        bw = np.abs(kw * dT[:, None] * uw) * 1.05 + 2 * fit_w + 1e-9
        ch.check("thermal %s: scale change dropped, residual within it (max %.2g of bound %.2g)"
                 % (to, np.abs(pa - ua).max(), ba.max()),
                 np.all(np.abs(pa - ua) <= ba) and np.all(np.abs(pw - uw) <= bw)
                 and "scale change" in text and np.abs(pa - ua).max() > 1e-6,
                 "excess %g %g" % ((np.abs(pa - ua) - ba).max(), (np.abs(pw - uw) - bw).max()))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("imubench")
    ap.add_argument("--work", required=True)
    ap.add_argument("--real", default="")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    ch = Checks(a.imubench, a.work)
    rng = np.random.default_rng(29)
    try:
        constant_case(ch, "no-misalignment", coeffs(rng, mis=False, gyro_scale=False), rng, False)
        constant_case(ch, "full", coeffs(rng), rng, True)
        thermal_case(ch, rng)
    except RuntimeError as e:
        ch.check("export ran", False, str(e))
    print("%d checks passed, %d failed" % (ch.passed, len(ch.failed)))
    if not ch.failed:
        print("export cases as expected")
    sys.exit(1 if ch.failed else 0)


if __name__ == "__main__":
    main()
