#!/usr/bin/env python3
"""Independent logger-file writer and checks for `imubench import-csv` (issue 29 item 1).

Writes logger text/CSV files in every supported shape from a known motion (Python + numpy,
sharing no code with imubench: its own motion, units, file layouts), imports each with
`imubench import-csv`, and checks the imubench-csv/1 recording it writes against the known
values (interchange.md: imu.csv t = END of the interval, increments = rate * interval), the
timing report (import.json) and the refusals (every bad row named at file:line, nothing
written). Then a real file (imu-calib's MPU-9150 log) imported and calibrated to the same
coefficients as its --format reader.

Usage: import_cases.py IMUBENCH --work DIR [--real DIR]
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

G0 = 9.80665  # the unit g
DEG = np.pi / 180.0


def motion(n, dt, seed=1):
    """A hand-held-like sequence: six static faces joined by 90-degree turns about one axis.
    Returns times (s), rates (rad/s, n x 3), specific force (m/s^2, n x 3)."""
    rng = np.random.default_rng(seed)
    t = np.arange(1, n + 1) * dt
    w = np.zeros((n, 3))
    f = np.zeros((n, 3))
    faces = [(0, 0, 1), (1, 0, 0), (0, 0, -1), (-1, 0, 0), (0, 1, 0), (0, -1, 0)]
    seg = n // len(faces)
    for k, face in enumerate(faces):
        sl = slice(k * seg, (k + 1) * seg if k < len(faces) - 1 else n)
        f[sl] = 9.81 * np.array(face, dtype=float)
        turn = slice(k * seg + seg // 2, k * seg + seg // 2 + seg // 5)
        w[turn, (k % 3)] = 0.5  # a turn: gyro above the static threshold there
    w += 0.001 * rng.standard_normal((n, 3))
    f += 0.01 * rng.standard_normal((n, 3))
    # during turns the accelerometer is not static: leave |f| at g (a pure rotation)
    return t, w, f


def write(path, rows, header=None, delim=",", newline="\n"):
    with open(path, "w", newline="") as fh:
        if header is not None:
            fh.write(delim.join(header) + newline)
        for r in rows:
            fh.write(delim.join(r) + newline)


def fmt(x):
    return repr(float(x))


def run(bin_, args):
    p = subprocess.run([bin_] + args, capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout + p.stderr


def read_imu(d):
    a = np.genfromtxt(os.path.join(d, "imu.csv"), delimiter=",", skip_header=1)
    return a[:, 0], a[:, 1:4], a[:, 4:7]


class Cases:
    def __init__(self, bin_, work):
        self.bin = bin_
        self.work = work
        self.failed = []
        self.passed = 0

    def check(self, name, ok, detail=""):
        print(("ok    " if ok else "FAIL  ") + name + ("" if ok else ": " + detail))
        if ok:
            self.passed += 1
        else:
            self.failed.append(name)

    def path(self, name):
        return os.path.join(self.work, name)

    def imported(self, name, files, args):
        out = self.path(name + ".dir")
        code, text = run(self.bin, ["import-csv"] + files + args + ["--out", out])
        return code, text, out

    def expect_increments(self, name, out, t, w, f, rtol=1e-12):
        ti, dth, dv = read_imu(out)
        dt = np.diff(np.concatenate([[t[0] - np.median(np.diff(t))], t]))
        ok = (len(ti) == len(t) and np.allclose(ti, t, rtol=0, atol=1e-12)
              and np.allclose(dth, w * dt[:, None], rtol=rtol, atol=1e-15)
              and np.allclose(dv, f * dt[:, None], rtol=rtol, atol=1e-13))
        self.check(name + ": increments = reading x interval", ok,
                   "rows %d vs %d" % (len(ti), len(t)))

    # ---- the shapes ----

    def basic(self):
        n, dt = 3000, 0.01
        t, w, f = motion(n, dt)
        rows = [[fmt(ti * 1e3), fmt(a[0] / G0), fmt(a[1] / G0), fmt(a[2] / G0),
                 fmt(b[0] / DEG), fmt(b[1] / DEG), fmt(b[2] / DEG)] for ti, a, b in zip(t, f, w)]
        p = self.path("basic.csv")
        write(p, rows, ["time_ms", "ax", "ay", "az", "gx", "gy", "gz"])
        code, text, out = self.imported("basic", [p], [
            "--columns", "t=time_ms,wx=gx,wy=gy,wz=gz,ax=ax,ay=ay,az=az",
            "--units", "t=ms,w=deg/s,a=g", "--gravity", "9.81"])
        self.check("basic: exit 0", code == 0, text)
        if code == 0:
            self.expect_increments("basic", out, t, w, f, rtol=1e-9)
            rep = json.load(open(os.path.join(out, "import.json")))
            self.check("basic: rate 100 Hz measured", abs(rep["timing"]["rate_hz"] - 100) < 1e-6,
                       str(rep["timing"]))
            meta = json.load(open(os.path.join(out, "meta.json")))
            self.check("basic: meta gravity", meta["site"].get("gravity_mps2") == 9.81, str(meta))
            tab = open(os.path.join(out, "table.csv")).read().splitlines()
            self.check("basic: no table angles (header only)", tab == ["t,outer,inner"], str(tab))

    def irregular(self):
        rng = np.random.default_rng(5)
        n = 2000
        dts = 0.01 * (1 + 0.1 * rng.uniform(-1, 1, n))
        dts[700] = 0.05   # a gap (4 missing samples)
        dts[1500] = 0.031
        t = np.cumsum(dts)
        _, w, f = motion(n, 0.01)
        rows = [[fmt(ti), fmt(a[0]), fmt(a[1]), fmt(a[2]), fmt(b[0]), fmt(b[1]), fmt(b[2])]
                for ti, a, b in zip(t, f, w)]
        p = self.path("irregular.csv")
        write(p, rows, ["t", "ax", "ay", "az", "wx", "wy", "wz"])
        code, text, out = self.imported("irregular", [p], [
            "--time", "t:s", "--columns", "wx=wx,wy=wy,wz=wz,ax=ax,ay=ay,az=az",
            "--units", "w=rad/s,a=m/s^2", "--latitude", "48"])
        self.check("irregular: exit 0", code == 0, text)
        if code != 0:
            return
        self.expect_increments("irregular", out, t, w, f)
        rep = json.load(open(os.path.join(out, "import.json")))["timing"]
        gaps = [g["where"] for g in rep["gaps"]]
        # data row k (0-based) is on line k + 2 (header on line 1)
        want = [p + ":%d" % (700 + 2), p + ":%d" % (1500 + 2)]
        self.check("irregular: both gaps named at file:line", gaps == want, "%s vs %s" % (gaps, want))
        med = np.median(np.diff(t))
        normal = np.diff(t)[np.diff(t) <= 1.5 * med]
        jit = np.sqrt(np.mean((normal - med) ** 2))
        self.check("irregular: median and jitter measured",
                   abs(rep["median_dt_s"] - med) < 1e-12 and abs(rep["jitter_rms_s"] - jit) < 1e-9,
                   "%s vs median %g jitter %g" % (rep, med, jit))
        # resampling only when asked: area preserved
        code, text, out2 = self.imported("irregular_rs", [p], [
            "--time", "t:s", "--columns", "wx=wx,wy=wy,wz=wz,ax=ax,ay=ay,az=az",
            "--units", "w=rad/s,a=m/s^2", "--latitude", "48", "--resample", "50"])
        ok = code == 0
        if ok:
            tr, dthr, dvr = read_imu(out2)
            _, dth, dv = read_imu(out)
            med0 = np.median(np.diff(t))
            cum = np.concatenate([[np.zeros(3)], np.cumsum(dth, 0)])
            tc = np.concatenate([[t[0] - med0], t])
            want = np.array([np.interp(tr[-1], tc, cum[:, k]) for k in range(3)])
            ok = (np.allclose(np.diff(tr), 0.02, atol=1e-9)
                  and np.allclose(np.sum(dthr, 0), want, rtol=0, atol=1e-12))
        self.check("irregular: --resample 50 gives a 50 Hz grid, angle kept", ok, text)

    def counts(self):
        n, dt = 2400, 0.005
        t, w, f = motion(n, dt)
        cw = np.round(w / DEG * 131.0)     # 131 LSB per deg/s
        ca = np.round(f / G0 * 16384.0)    # 16384 LSB per g
        rows = [["%d" % round(ti * 1e6)] + ["%d" % v for v in a] + ["%d" % v for v in b]
                for ti, a, b in zip(t, ca, cw)]
        p = self.path("counts.txt")
        write(p, rows, None, delim="\t")
        code, text, out = self.imported("counts", [p], [
            "--columns", "t=1,ax=2,ay=3,az=4,wx=5,wy=6,wz=7",
            "--units", "t=us,w=lsb:131:deg/s,a=lsb:16384:g", "--gravity", "9.81"])
        self.check("counts: exit 0 (tab, no header, LSB scales)", code == 0, text)
        if code == 0:
            self.expect_increments("counts", out, np.round(t * 1e6) * 1e-6,
                                   cw / 131.0 * DEG, ca / 16384.0 * G0, rtol=1e-9)
        # the same with counts:K:U (units per count)
        code, text, out = self.imported("counts_k", [p], [
            "--columns", "t=1,ax=2,ay=3,az=4,wx=5,wy=6,wz=7",
            "--units", "t=us,w=count:%r:deg/s,a=count:%r:m/s^2" % (1 / 131.0, G0 / 16384.0),
            "--gravity", "9.81"])
        if code == 0:
            self.expect_increments("counts count:K:U", out, np.round(t * 1e6) * 1e-6,
                                   cw / 131.0 * DEG, ca / 16384.0 * G0, rtol=1e-9)
        else:
            self.check("counts count:K:U: exit 0", False, text)

    def two_files(self):
        n, dt = 2000, 0.01
        t, w, f = motion(n, dt)
        pa, pg = self.path("acc.csv"), self.path("gyr.csv")
        write(pa, [[fmt(ti), fmt(a[0]), fmt(a[1]), fmt(a[2])] for ti, a in zip(t, f)],
              ["timestamp", "x", "y", "z"])
        # the gyro logger prints its stamps rounded to 0.1 ms
        tg = np.round(t, 4)
        write(pg, [[fmt(ti), fmt(b[0]), fmt(b[1]), fmt(b[2])] for ti, b in zip(tg, w)]
              + [[fmt(t[-1] + 0.5), "0", "0", "0"]], ["timestamp", "gx", "gy", "gz"])
        args = ["--columns", "t=timestamp,ax=x,ay=y,az=z,wx=gx,wy=gy,wz=gz",
                "--units", "t=s,w=rad/s,a=m/s^2", "--gravity", "9.81"]
        code, text, out = self.imported("two", [pa, pg], args)
        self.check("two files: the unpaired gyro row refused at file:line",
                   code == 1 and (pg + ":%d" % (n + 2)) in text and not os.path.exists(out), text)
        code, text, out = self.imported("two_skip", [pa, pg], args + ["--skip-bad-rows"])
        self.check("two files: --skip-bad-rows exit 0", code == 0, text)
        if code == 0:
            self.expect_increments("two files", out, t, w, f)
            rep = json.load(open(os.path.join(out, "import.json")))
            self.check("two files: the left-out row listed",
                       [b["where"] for b in rep["bad_rows"]] == [pg + ":%d" % (n + 2)], str(rep["bad_rows"]))

    def swapped_missing(self):
        n, dt = 1500, 0.01
        t, w, f = motion(n, dt)
        header = ["gz", "az", "t", "ax", "gy", "ay", "gx", "note"]
        rows = [[fmt(b[2]), fmt(a[2]), fmt(ti), fmt(a[0]), fmt(b[1]), fmt(a[1]), fmt(b[0]), "x"]
                for ti, a, b in zip(t, f, w)]
        p = self.path("swapped.csv")
        write(p, rows, header)
        code, text, out = self.imported("swapped", [p], [
            "--columns", "t=t,wx=gx,wy=gy,wz=gz,ax=ax,ay=ay,az=az",
            "--units", "t=s,w=rad/s,a=m/s^2", "--gravity", "9.81"])
        self.check("swapped columns by name: exit 0", code == 0, text)
        if code == 0:
            self.expect_increments("swapped columns", out, t, w, f)
        code, text, out = self.imported("swapped_idx", [p], [
            "--columns", "t=3,wx=7,wy=5,wz=1,ax=4,ay=6,az=2",
            "--units", "t=s,w=rad/s,a=m/s^2", "--gravity", "9.81"])
        if code == 0:
            self.expect_increments("swapped columns by index", out, t, w, f)
        else:
            self.check("swapped columns by index: exit 0", False, text)
        code, text, out = self.imported("missing", [p], [
            "--columns", "t=t,wx=gx,wy=gy,wz=wz_missing,ax=ax,ay=ay,az=az",
            "--units", "t=s,w=rad/s,a=m/s^2", "--gravity", "9.81"])
        self.check("missing column refused, naming it and the header",
                   code == 1 and "wz_missing" in text and "gz, az, t" in text
                   and not os.path.exists(out), text)

    def bad_rows(self):
        n, dt = 1200, 0.01
        t, w, f = motion(n, dt)
        rows = [[fmt(ti), fmt(a[0]), fmt(a[1]), fmt(a[2]), fmt(b[0]), fmt(b[1]), fmt(b[2])]
                for ti, a, b in zip(t, f, w)]
        rows[100][4] = "nan"                      # line 102
        rows[200] = rows[200][:5]                 # line 202: wrong column count
        rows[300][0] = fmt(t[298])                # line 302: time not increasing
        for k in range(400, 450):  # lines 402..451: m/s^2 read as g (|f| ~ 9.8 g) while still
            rows[k][1:4] = [fmt(x * 9.81) for x in f[k]]
        p = self.path("bad.csv")
        write(p, rows, ["t", "ax", "ay", "az", "wx", "wy", "wz"], delim=";", newline="\r\n")
        args = ["--columns", "t=t,wx=wx,wy=wy,wz=wz,ax=ax,ay=ay,az=az",
                "--units", "t=s,w=rad/s,a=m/s^2", "--gravity", "9.81"]
        code, text, out = self.imported("bad", [p], args)
        want = [p + ":102: column wx", p + ":202: expected 7 columns",
                p + ":302: time", p + ":427: implausible static specific force"]
        self.check("bad rows (CRLF, ';'): each named at file:line, nothing written",
                   code == 1 and all(x in text for x in want) and " bad rows" in text
                   and not os.path.exists(out), text)
        code, text, out = self.imported("bad_skip", [p], args + ["--skip-bad-rows"])
        ok = code == 0
        if ok:
            rep = json.load(open(os.path.join(out, "import.json")))
            ti, _, _ = read_imu(out)
            nb = len(rep["bad_rows"])
            ok = (nb >= 4 and rep["bad_rows_left_out"] == nb and len(ti) == n - nb
                  and rep["samples"] == n - nb
                  and all(b["where"].startswith(p + ":") for b in rep["bad_rows"]))
        self.check("bad rows: --skip-bad-rows leaves them out, each listed", ok, text)

    def increments_ws(self):
        n, dt = 1000, 0.0025
        t, w, f = motion(n, dt)
        rows = [["%d" % round(ti * 1e9)] + [fmt(x * dt) for x in b] + [fmt(x * dt) for x in a]
                for ti, a, b in zip(t, f, w)]
        p = self.path("incr.txt")
        write(p, rows, ["#", "t_ns", "dthx", "dthy", "dthz", "dvx", "dvy", "dvz"], delim="  ")
        code, text, out = self.imported("incr", [p], [
            "--columns", "t=1,wx=2,wy=3,wz=4,ax=5,ay=6,az=7",
            "--units", "t=ns,w=rad,a=m/s", "--gravity", "9.81"])
        self.check("increments, whitespace, ns time, comment line: exit 0", code == 0, text)
        if code == 0:
            ti, dth, dv = read_imu(out)
            self.check("increments copied as logged",
                       np.allclose(dth, w * dt, rtol=1e-12, atol=1e-18)
                       and np.allclose(dv, f * dt, rtol=1e-12, atol=1e-16), "")

    def hint(self):
        p = self.path("basic.csv")
        code, text = run(self.bin, ["calibrate", p])
        self.check("calibrate FILE: hint names import-csv and the header",
                   code != 0 and "import-csv" in text and "time_ms" in text, text)

    def real(self, real_dir):
        log = os.path.join(real_dir, "mikoff_mpu9150_imu0.log")
        code, text, out = self.imported("mikoff", [log], [
            "--columns", "ax=1,ay=2,az=3,wx=4,wy=5,wz=6", "--units", "a=m/s^2,w=rad/s",
            "--rate", "100", "--gravity", "9.81"])
        self.check("real: imu-calib log imported", code == 0, text)
        if code != 0:
            return
        c1, j1 = run(self.bin, ["calibrate", out, "--method", "scalar", "--json"])
        c2, j2 = run(self.bin, ["calibrate", log, "--format", "imu-calib", "--json"])
        if c1 != 0 or c2 != 0:
            self.check("real: both calibrate", False, j1 + j2)
            return

        def coeffs(text):
            return json.loads(text[text.index("{"):text.rindex("}") + 1])

        # The scalar calibration of a recording takes each reading at the middle of its
        # interval (t - dt/2), the --format reader at its stamp: the same data half a sample
        # apart, which moves the static spans' edges by a sample. The coefficients must agree
        # to a small fraction of their own sigma.
        a, b = coeffs(j1), coeffs(j2)
        worst, worst_z = 0.0, 0.0
        for tri in ("accel", "gyro"):
            for key in ("scale", "bias", "misalignment"):
                va, vb = a[tri][key], b[tri][key]
                sg = b[tri].get("sigma", {}).get(key)
                keys = list(va) if isinstance(va, dict) else range(3)
                for k in keys:
                    d = abs(va[k] - vb[k])
                    worst = max(worst, d)
                    s_k = (sg.get(k, 0.0) if isinstance(sg, dict) else sg[k]) if sg is not None else 0.0
                    if s_k:
                        worst_z = max(worst_z, d / s_k)
                    elif d > 1e-12:
                        worst_z = float("inf")
        self.check("real: same coefficients as --format imu-calib (max diff %.3g, %.3g sigma)"
                   % (worst, worst_z), worst_z < 0.2, "")
        # Without --method: the recording has no table angles, so the scalar calibration is
        # chosen (and said), with the same coefficients.
        c3, j3 = run(self.bin, ["calibrate", out, "--json"])
        self.check("real: calibrate without --method chooses scalar",
                   c3 == 0 and "method: scalar" in j3 and coeffs(j3) == a, j3[-400:])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("imubench")
    ap.add_argument("--work", required=True)
    ap.add_argument("--real", default=os.path.join(os.path.dirname(__file__), "..", "..", "..",
                                                   "shared", "data", "real"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    for name in os.listdir(a.work):
        full = os.path.join(a.work, name)
        if os.path.isdir(full):
            subprocess.run(["rm", "-rf", full])
    c = Cases(a.imubench, a.work)
    for case in (c.basic, c.irregular, c.counts, c.two_files, c.swapped_missing, c.bad_rows,
                 c.increments_ws, c.hint):
        case()
    c.real(a.real)
    print("%d checks passed, %d failed%s" % (c.passed, len(c.failed),
                                            (": " + ", ".join(c.failed)) if c.failed else ""))
    if not c.failed:
        print("import cases as expected")
    sys.exit(1 if c.failed else 0)


if __name__ == "__main__":
    main()
