#!/usr/bin/env python3
"""Independent static recordings for `imubench nav DIR --align SECONDS` (issue 29 item 2).

Writes table-free imubench-csv/1 recordings (interchange.md only; no code shared with
imubench) of an IMU at rest at a known attitude, with navigation-grade white noise, and checks
that the heading `nav --align` prints is within its own stated uncertainty (3 sigma, plus the
stated heading per gyro bias where a bias is written); a ship and a vehicle swaying (no static
span) aligned through the sway, heading within the stated uncertainty; a span too short for the
sway, a consumer gyro and the real hand-held imu-calib log (MPU-9150: gyro bias ~360 times the
Earth rate) refused (exit 3) with the reason, levelling only where the gyro is the reason.

Usage: align_cases.py IMUBENCH --work DIR [--real DIR]
"""
import argparse
import json
import os
import re
import subprocess
import sys

import numpy as np

W = 7.292115e-5
DEG = np.pi / 180


def rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def write(d, lat_deg, C_LB_of_t, T, rate, rng, gyro_bias=np.zeros(3), g=9.81,
          accel_L_of_t=lambda t: np.zeros(3)):
    os.makedirs(d, exist_ok=True)
    n = int(T * rate)
    dt = 1.0 / rate
    lat = lat_deg * DEG
    w_L = np.array([0, W * np.cos(lat), W * np.sin(lat)])
    rows = []
    for k in range(1, n + 1):
        t = k * dt
        C = C_LB_of_t(t - dt / 2)
        # specific force: gravity's reaction plus the point's own acceleration (heave, surge)
        f = C.T @ (np.array([0, 0, g]) + accel_L_of_t(t - dt / 2))
        # sway: the attitude's own rate from a central difference of C (small angles)
        C1, C0 = C_LB_of_t(t - dt / 2 + 1e-4), C_LB_of_t(t - dt / 2 - 1e-4)
        S = C.T @ (C1 - C0) / 2e-4
        w = C.T @ w_L + np.array([S[2, 1], S[0, 2], S[1, 0]]) + gyro_bias
        w = w + 5.8e-6 * rng.standard_normal(3)
        f = f + 2e-3 * rng.standard_normal(3)
        rows.append([t, *(w * dt), *(f * dt), 20.0])
    json.dump({"format": "imubench-csv/1",
               "site": {"latitude_deg": lat_deg, "height_m": 0.0, "gravity_mps2": g},
               "imu": {"serial": "A1", "rate_hz": rate}, "table": {"kind": "two-axis"}},
              open(os.path.join(d, "meta.json"), "w"))
    with open(os.path.join(d, "imu.csv"), "w") as fh:
        fh.write("t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n")
        for r in rows:
            fh.write(",".join(repr(float(x)) for x in r) + "\n")
    open(os.path.join(d, "table.csv"), "w").write("t,outer,inner\n")


def heading_of(C):
    y = C[:, 1]  # the body y axis in ENU
    return np.arctan2(y[0], y[1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("imubench")
    ap.add_argument("--work", required=True)
    ap.add_argument("--real", default="")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rng = np.random.default_rng(7)
    failed, passed = [], 0

    def check(name, ok, detail=""):
        nonlocal passed
        print(("ok    " if ok else "FAIL  ") + name + ("" if ok else ": " + detail))
        if ok:
            passed += 1
        else:
            failed.append(name)

    def nav(d, secs):
        p = subprocess.run([a.imubench, "nav", d, "--align", str(secs), "--every", "60"],
                           capture_output=True, text=True, timeout=300)
        return p.returncode, p.stdout + p.stderr

    for name, lat, psi, bias in (("static", 50.0, 37.0, 0.0), ("static_south", -33.0, 212.0, 0.0),
                                 ("static_bias", 50.0, 100.0, 0.05)):
        C = rot(2, -psi * DEG) @ rot(0, -3 * DEG) @ rot(1, 2 * DEG)
        b_E = bias * DEG / 3600  # deg/h East (L frame) gyro bias, in B
        d = os.path.join(a.work, name)
        write(d, lat, lambda t: C, 300, 100, rng, gyro_bias=C.T @ np.array([b_E, 0, 0]))
        code, out = nav(d, 300)
        m = re.search(r"heading (-?[\d.]+) deg\n", out)
        s = re.search(r"tilt ([\d.e+-]+) deg, heading ([\d.e+-]+) deg", out)
        per = re.search(r"= ([\d.e+-]+) deg of heading per 0.01 deg/h", out)
        if code != 0 or not (m and s and per):
            check(name + ": aligned", False, out)
            continue
        err = (float(m.group(1)) - heading_of(C) / DEG + 180) % 360 - 180
        sigma = float(s.group(2))
        allowed = 3 * sigma + float(per.group(1)) * bias / 0.01
        check("%s: heading error %.4f deg within 3 sigma %.4f (+ stated bias term) = %.4f"
              % (name, err, 3 * sigma, allowed), abs(err) <= allowed and sigma > 0, out)
        if bias:
            check(name + ": the bias term is needed (error beyond 3 sigma alone)",
                  abs(err) > 3 * sigma, "err %g" % err)
    # sway: +-0.5 deg roll at 0.2 Hz (a ship or a vehicle on its suspension): the span's
    # average removes it; heading within the stated uncertainty. A short span (less than the
    # static test's blocks can average) is refused, not aligned wrongly.
    C0 = rot(2, -37 * DEG)
    d = os.path.join(a.work, "sway")
    write(d, 50.0, lambda t: C0 @ rot(1, 0.5 * DEG * np.sin(2 * np.pi * 0.2 * t)), 120, 100, rng)
    code, out = nav(d, 100)
    m = re.search(r"heading (-?[\d.]+) deg\n", out)
    s = re.search(r"tilt ([\d.e+-]+) deg, heading ([\d.e+-]+) deg", out)
    if code == 0 and m and s:
        err = (float(m.group(1)) - heading_of(C0) / DEG + 180) % 360 - 180
        check("sway: heading error %.4f deg within 3 sigma %.4f" % (err, 3 * float(s.group(2))),
              abs(err) <= 3 * float(s.group(2)) and float(s.group(2)) < 1.0, out)
    else:
        check("sway: aligned", False, out)
    code, out = nav(d, 3)
    check("sway, 3 s span: refused with exit 3 and the reason", code == 3 and "not static" in out
          and "refused" in out and "gyro bias that large" not in out, out)

    # Large sway that no static test passes, over spans that hold no whole number of periods:
    # a ship (roll +-4 deg at 9.3 s, pitch +-1.5 deg at 6.7 s, yaw +-0.8 deg at 12.1 s, heave
    # 0.5 m/s^2 at 8.1 s, surge 0.2 m/s^2 at 10.3 s) and a vehicle on its suspension (engine
    # running: roll +-1.5 deg at 1.3 s, pitch +-1 deg at 0.9 s, vertical 1 m/s^2 at 0.6 s).
    # Heading at the span's start within 3 of the alignment's own sigmas, the sway method used.
    def sway(C_h, periods, amps, phases):
        def C(t):
            r = [a * DEG * np.sin(2 * np.pi * t / p + ph) for a, p, ph in zip(amps, periods, phases)]
            return C_h @ rot(2, r[2]) @ rot(0, r[1]) @ rot(1, r[0])
        return C

    def accel(amps, periods):
        return lambda t: np.array([a * np.sin(2 * np.pi * t / p + 0.3)
                                   for a, p in zip(amps, periods)])

    for name, lat, psi, T, C_of_t, acc in (
            ("ship", 50.0, 123.0, 290.7,
             sway(rot(2, -123 * DEG), (9.3, 6.7, 12.1), (4.0, 1.5, 0.8), (0.4, 1.1, 2.0)),
             accel((0.0, 0.2, 0.5), (1.0, 10.3, 8.1))),
            ("vehicle", -33.0, 250.0, 183.3,
             sway(rot(2, -250 * DEG) @ rot(0, 2 * DEG), (1.3, 0.9, 2.3), (1.5, 1.0, 0.3),
                  (0.2, 0.7, 1.5)),
             accel((0.05, 0.1, 1.0), (2.9, 3.7, 0.6)))):
        d = os.path.join(a.work, name)
        write(d, lat, C_of_t, T, 100, rng, accel_L_of_t=acc)
        code, out = nav(d, T)
        m = re.search(r"heading (-?[\d.]+) deg\n", out)
        s = re.search(r"tilt ([\d.e+-]+) deg, heading ([\d.e+-]+) deg", out)
        if code != 0 or not (m and s and "sway-tolerant alignment" in out):
            check(name + ": aligned through the sway", False, out)
            continue
        err = (float(m.group(1)) - heading_of(C_of_t(0.0)) / DEG + 180) % 360 - 180
        sigma = float(s.group(2))
        # The stated sigma models the sway's left-over velocity changes as telescoping over the
        # span (and the gyros' random walk as correlated): honest here, a heading and not a guess
        # (sigma under 15 deg); its calibration over many seeds is the nav unit test's.
        check("%s: heading error %.4f deg within 3 sigma %.4f (sigma < 15 deg)"
              % (name, err, 3 * sigma), abs(err) <= 3 * sigma and 0 < sigma < 15.0, out)
        lat_m = re.search(r"latitude the Earth rate implies: (-?[\d.]+) \+- ([\d.]+) deg", out)
        check(name + ": implied latitude within 3 of its sigmas",
              bool(lat_m) and abs(float(lat_m.group(1)) - lat) <= 3 * float(lat_m.group(2)), out)
    # A consumer gyro (bias 1 deg/s, far above the Earth rate) at rest: refused with the
    # reason, levelling only.
    C = rot(2, -40 * DEG) @ rot(0, 5 * DEG)
    d = os.path.join(a.work, "consumer")
    write(d, 50.0, lambda t: C, 120, 100, rng, gyro_bias=np.array([0.6, -0.5, 0.6]) * DEG)
    code, out = nav(d, 60)
    check("consumer gyro: refused (exit 3), gyro bias named, levelling printed",
          code == 3 and "cannot gyrocompass" in out and "levelling only" in out, out)
    if a.real:
        log = os.path.join(a.real, "mikoff_mpu9150_imu0.log")
        d = os.path.join(a.work, "mikoff")
        p = subprocess.run([a.imubench, "import-csv", log, "--columns",
                            "ax=1,ay=2,az=3,wx=4,wy=5,wz=6", "--units", "a=m/s^2,w=rad/s",
                            "--rate", "100", "--gravity", "9.81", "--out", d],
                           capture_output=True, text=True)
        code, out = nav(d, 3)
        check("real hand-held log: alignment refused (exit 3), the consumer gyro named, "
              "levelling only", p.returncode == 0 and code == 3 and "refused" in out
              and "cannot gyrocompass" in out and "levelling only" in out, out)
    print("%d checks passed, %d failed" % (passed, len(failed)))
    if not failed:
        print("align cases as expected")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
