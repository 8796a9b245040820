#!/usr/bin/env python3
"""Independent recording writer: imubench-csv/1 recordings of a simulated IMU on a two- or
three-axis table, derived ONLY from interchange.md (frames, table chains with every geometric
error, the sensor equation, the recording CSV form, segments, the coefficient/truth file).
It shares no code with imubench's C++ simulator: its own schedule, timing grid, motion
profile, integration and segmentation, so the calibrators are tested on the physics, not on
the conventions of the program that wrote their usual input.

Physics (interchange.md):
  L = ENU, C_LB maps B to L. Two-axis: C_LB = Th H Rx(o + o0) Nu Rz(i + i0) Mu,
  H = Rz(pi/2 - heading); three-axis: C_LB = Th Rz(o + o0) Nu1 Rx(m + m0) Nu2 Rz(i + i0) Mu.
  Every small-error factor (I + [t x]) is taken as the rotation exp([t x]) (a physical table is
  a rotation; the two agree to first order, and the exact form also holds for 1 degree).
  At the axes' intersection (no lever arm): f_B = C_LB^T (0, 0, g),
  w_IB_B = C_LB^T w_ie_L + w_LB_B, w_ie_L = Omega (0, cos lat, sin lat);
  w_LB_B from C_LB' = C_LB [w_LB_B x]: a joint with rate q' and right-hand product P adds
  q' P^T e_axis.
  reading = diag(scale) (M input - bias + noise); the increments are the integral of the
  reading over the sample interval (Gauss-Legendre quadrature of the smooth motion).

Usage: write_recording.py OUT_DIR --case NAME   (names: see CASES at the bottom)
       write_recording.py OUT_DIR --case NAME --plan PLAN.toml [--seed N]: the case's IMU,
         table errors and extras on the plan's motion (docs/plan-format.md steps move, rotate,
         rate, hold, repeat, record on; read with tomllib, the writer's own cosine-ramp
         profile within each step's rate and acceleration, its own timing grid)
"""
import argparse
import json
import os

import numpy as np

EARTH_RATE = 7.292115e-5  # rad/s (interchange.md)
ARCSEC = np.pi / (180.0 * 3600.0)
DEG = np.pi / 180.0


def normal_gravity(lat_rad, h_m):
    """WGS-84 normal gravity (Somigliana) with the second-order height correction."""
    a, f, m = 6378137.0, 1.0 / 298.257223563, 0.00344978650684
    ge, k, e2 = 9.7803253359, 0.00193185265241, 0.00669437999013
    s2 = np.sin(lat_rad) ** 2
    g0 = ge * (1.0 + k * s2) / np.sqrt(1.0 - e2 * s2)
    return g0 * (1.0 - 2.0 / a * (1.0 + f + m - 2.0 * f * s2) * h_m + 3.0 * h_m**2 / a**2)


# ---- rotations (batched: angle arrays of shape (n,) give (n, 3, 3)) ----

def rot(axis, ang):
    ang = np.asarray(ang, dtype=float)
    c, s = np.cos(ang), np.sin(ang)
    R = np.zeros(ang.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def exp_rot(v):
    """exp([v x]) (Rodrigues) of one small rotation vector."""
    v = np.asarray(v, dtype=float)
    th = np.linalg.norm(v)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    if th < 1e-300:
        return np.eye(3)
    return np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th**2 * K @ K


# ---- the table ----

class Table:
    """Chain of interchange.md with every geometric error (rad)."""

    def __init__(self, kind, heading_deg=90.0, theta=(0, 0), nu=(0, 0, 0), mu=(0, 0), zero=(0, 0, 0)):
        self.kind = kind
        self.naxes = 2 if kind == "two-axis" else 3
        self.heading_deg = heading_deg
        self.theta, self.nu, self.mu, self.zero = (np.array(theta, float), np.array(nu, float),
                                                   np.array(mu, float), np.array(zero, float))
        H = rot(2, np.pi / 2 - heading_deg * DEG) if kind == "two-axis" else np.eye(3)
        self.A0 = exp_rot([theta[0], theta[1], 0.0]) @ H
        if kind == "two-axis":  # nu = (nu_y,): factor after the outer joint
            self.A1 = exp_rot([0.0, nu[0], 0.0])
            self.A2 = np.eye(3)
        else:  # nu = (nu1_x, nu1_y, nu2_y)
            self.A1 = exp_rot([nu[0], nu[1], 0.0])
            self.A2 = exp_rot([0.0, nu[2], 0.0])
        self.A3 = exp_rot([mu[0], mu[1], 0.0])
        # joint axes: two-axis (x, z); three-axis (z, x, z)
        self.joint_axes = [0, 2] if kind == "two-axis" else [2, 0, 2]

    def kinematics(self, q, qdot):
        """C_LB (n,3,3) and w_LB_B (n,3) for encoder readings q (n, naxes) and rates."""
        phys = q + self.zero[: self.naxes]
        if self.kind == "two-axis":
            factors = [self.A0, None, self.A1, None, self.A3]
        else:
            factors = [self.A0, None, self.A1, None, self.A2, None, self.A3]
        n = q.shape[0]
        # right-hand products P_k for each joint, built from the right
        right = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        w = np.zeros((n, 3))
        joint = self.naxes - 1
        for f in reversed(factors):
            if f is None:
                ax = self.joint_axes[joint]
                w += qdot[:, joint, None] * right[:, ax, :]  # P^T e_ax = row ax of P
                right = rot(ax, phys[:, joint]) @ right
                joint -= 1
            else:
                right = f @ right
        return right, w


# ---- the sensor ----

class Triad:
    def __init__(self, scale, bias, mis):
        self.scale = np.array(scale, float)
        self.bias = np.array(bias, float)
        self.mis = dict(mis)  # xy, xz, yx, yz, zx, zy
        m = self.mis
        self.M = np.array([[1, m["xy"], -m["xz"]], [-m["yx"], 1, m["yz"]], [m["zx"], -m["zy"], 1]])

    def reading(self, inp):
        return (inp @ self.M.T - self.bias) * self.scale

    def reading_at_points(self, inp_x, inp_y, inp_z):
        """Axis k senses the input at its own point (interchange.md size_effect): inp_k (n, 3)."""
        u = np.stack([inp_x @ self.M[0], inp_y @ self.M[1], inp_z @ self.M[2]], axis=-1)
        return (u - self.bias) * self.scale

    def json(self):
        return {"scale": list(self.scale), "bias": list(self.bias), "misalignment": self.mis}


def graded_triad(rng, bias_range):
    """A navigation/tactical-grade triad: |scale - 1| 100-1000 ppm, misalignments 30-300
    arcsec, |bias| in bias_range, random signs."""
    keys = ["xy", "xz", "yx", "yz", "zx", "zy"]

    def signed(lo, hi, n=None):
        return rng.choice([-1.0, 1.0], n) * rng.uniform(lo, hi, n)
    return Triad(1 + signed(100.0, 1000.0, 3) * 1e-6, signed(*bias_range, 3),
                 {k: float(signed(30.0, 300.0) * ARCSEC) for k in keys})


def random_triad(rng, scale_ppm, bias, mis_rad):
    keys = ["xy", "xz", "yx", "yz", "zx", "zy"]
    return Triad(1 + rng.uniform(-scale_ppm, scale_ppm, 3) * 1e-6, rng.uniform(-bias, bias, 3),
                 {k: float(rng.uniform(-mis_rad, mis_rad)) for k in keys})


# ---- the schedule: holds and single-axis moves with a smooth (cosine-ramp) rate profile ----

class Schedule:
    def __init__(self, naxes, t0):
        self.naxes = naxes
        self.t = t0
        self.q = np.zeros(naxes)  # encoder readings, rad
        self.steps = []  # (t_start, t_end, axis or -1, q_start, delta, rate, ramp)
        self.kinds = []  # per step: "hold", "move" or "settle"
        self.last_axis = 0

    def hold(self, dur):
        self.steps.append((self.t, self.t + dur, -1, self.q.copy(), 0.0, 0.0, 0.0))
        self.kinds.append("hold")
        self.t += dur

    def settle(self, dur, amp_rad=0.0, freq_hz=4.0, decay_s=0.3):
        """The table at its target after a move; amp_rad > 0: a decaying servo oscillation of
        the axis that moved last, A exp(-tau/T) (1 - cos(2 pi f tau)) (angle and rate zero at
        the start, so the motion stays smooth; the encoders read it, it is real motion)."""
        self.steps.append((self.t, self.t + dur, self.last_axis, self.q.copy(), amp_rad, freq_hz,
                           decay_s))
        self.kinds.append("settle")
        self.t += dur

    def motion(self, legs, kind="move"):
        """Several axes starting together (a plan's move): legs = [(axis, delta_rad, rate_rad_s,
        ramp_s, flat_s)], each a cosine-ramp profile of its own; the step ends when the last
        axis arrives (the others hold at their targets)."""
        legs = [leg for leg in legs if abs(leg[1]) > 0.0]
        if not legs:
            return
        dur = max(2 * leg[3] + leg[4] for leg in legs)
        self.steps.append((self.t, self.t + dur, legs[0][0], self.q.copy(), legs, 0.0, 0.0))
        self.kinds.append("multi")
        self.t += dur
        for axis, d, *_ in legs:
            self.q[axis] += d
            self.last_axis = axis

    def move(self, axis, delta_deg, rate_dps=20.0, ramp_s=1.0):
        d = delta_deg * DEG
        w = min(rate_dps * DEG, abs(d) / ramp_s)
        dur = 2 * ramp_s + (abs(d) - w * ramp_s) / w
        self.steps.append((self.t, self.t + dur, axis, self.q.copy(), d, w, ramp_s))
        self.kinds.append("move")
        self.t += dur
        self.q[axis] += d
        self.last_axis = axis

    def state(self, t):
        """Encoder readings and rates at times t (n,) -> (n, naxes) each."""
        starts = np.array([s[0] for s in self.steps])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.steps) - 1)
        q = np.zeros((len(t), self.naxes))
        qd = np.zeros((len(t), self.naxes))
        for k in np.unique(idx):
            sel = idx == k
            t0, t1, axis, q0, d, w, Tr = self.steps[k]
            q[sel] = q0
            if self.kinds[k] == "settle":  # d: amplitude, w: frequency, Tr: decay time
                tau = np.clip(t[sel] - t0, 0.0, t1 - t0)
                env = d * np.exp(-tau / Tr)
                ph = 2 * np.pi * w * tau
                q[sel, axis] += env * (1 - np.cos(ph))
                qd[sel, axis] = env * (2 * np.pi * w * np.sin(ph) - (1 - np.cos(ph)) / Tr)
                continue
            if self.kinds[k] == "multi":  # d: the legs
                for ax, dl, wl, Trl, flat in d:
                    a, r = ramp_profile(t[sel] - t0, abs(dl), wl, Trl, 2 * Trl + flat)
                    q[sel, ax] += np.sign(dl) * a
                    qd[sel, ax] = np.sign(dl) * r
                continue
            if axis < 0:
                continue
            ang, rate = ramp_profile(t[sel] - t0, abs(d), w, Tr, t1 - t0)
            q[sel, axis] += np.sign(d) * ang
            qd[sel, axis] = np.sign(d) * rate
        return q, qd


def ramp_profile(tau, dist, w, Tr, T):
    """Angle and rate at tau of a turn of dist (> 0) in T: the rate rises as w (1 - cos(pi tau /
    Tr)) / 2 for Tr, stays w, and falls mirrored to 0 at T (zero rate and acceleration at both
    ends; peak acceleration w pi / (2 Tr))."""
    tau = np.clip(tau, 0.0, T)
    # rate: w (1 - cos(pi tau / Tr)) / 2 up, w flat, mirrored down
    up = w / 2 * (tau - Tr / np.pi * np.sin(np.pi * tau / Tr))
    r_up = w / 2 * (1 - np.cos(np.pi * tau / Tr))
    a_ramp = w * Tr / 2
    flat = a_ramp + w * (tau - Tr)
    td = T - tau  # time to the end
    down = dist - w / 2 * (td - Tr / np.pi * np.sin(np.pi * td / Tr))
    r_down = w / 2 * (1 - np.cos(np.pi * td / Tr))
    ang = np.where(tau < Tr, up, np.where(td < Tr, down, flat))
    rate = np.where(tau < Tr, r_up, np.where(td < Tr, r_down, w))
    return ang, rate


# ---- the recording ----

GL_X = np.array([-np.sqrt(3 / 5), 0.0, np.sqrt(3 / 5)])
GL_W = np.array([5 / 9, 8 / 9, 5 / 9])


def joint_state(sched, tt, extra):
    """True joint angles and rates at tt from the encoder's (Schedule.state). interchange.md
    angle_harmonic (axis, order k, cos_rad, sin_rad): true = encoder + c cos(k a) + s sin(k a),
    so the true rate is the encoder rate times 1 + k (s cos(k a) - c sin(k a))."""
    q, qd = sched.state(tt)
    if "angle_harmonic" in extra:
        axis, k, c, s = extra["angle_harmonic"]
        names = ["outer", "inner"] if sched.naxes == 2 else ["outer", "middle", "inner"]
        j = names.index(axis)
        a = q[:, j].copy()
        q[:, j] = a + c * np.cos(k * a) + s * np.sin(k * a)
        qd[:, j] = qd[:, j] * (1 + k * (s * np.cos(k * a) - c * np.sin(k * a)))
    return q, qd


def lever_arm_force(table, sched, tt, w_LB_B, r, extra, h=1e-4):
    """interchange.md lever_arm: w' x r + w x (w x r), w the table rate in B; w' by central
    differences of the table kinematics (h s)."""
    _, wp = table.kinematics(*joint_state(sched, tt + h, extra))
    _, wm = table.kinematics(*joint_state(sched, tt - h, extra))
    wdot = (wp - wm) / (2 * h)
    return np.cross(wdot, r) + np.cross(w_LB_B, np.cross(w_LB_B, r))


def integrate_increments(table, sched, accel, gyro, g, w_ie_L, t_end, dt, sub=2, extra=None):
    """Increments over (t_end - dt, t_end] by Gauss-Legendre (sub sub-intervals x 3 nodes).
    extra (interchange.md effect ids): "lever_arm" r_m (m, B); "size_effect" (d_y_m, d_z_m):
    the y and z accelerometers' points relative to the x one's (r_m); "time_delay" tau_s (a
    sample stamped t was taken at t - tau_s); "angle_harmonic" (axis, k, cos_rad, sin_rad)."""
    extra = extra or {}
    tau = extra.get("time_delay", 0.0)
    n = len(t_end)
    h = dt / sub
    offs = []
    wts = []
    for s in range(sub):
        for x, wgt in zip(GL_X, GL_W):
            offs.append(-dt + h * s + h * (x + 1) / 2)
            wts.append(wgt * h / 2)
    offs, wts = np.array(offs), np.array(wts)
    dth = np.zeros((n, 3))
    dv = np.zeros((n, 3))
    chunk = 20000
    for a in range(0, n, chunk):
        tt = (t_end[a:a + chunk, None] + offs[None, :]).ravel() - tau
        q, qd = joint_state(sched, tt, extra)
        C_LB, w_LB_B = table.kinematics(q, qd)
        C_BL = np.transpose(C_LB, (0, 2, 1))
        f_B = C_BL @ np.array([0.0, 0.0, g])
        r = np.array(extra.get("lever_arm", (0.0, 0.0, 0.0)), float)
        if "lever_arm" in extra:
            f_x = f_B + lever_arm_force(table, sched, tt, w_LB_B, r, extra)
        else:
            f_x = f_B
        w_IB_B = C_BL @ w_ie_L + w_LB_B
        if "size_effect" in extra:  # the y and z accelerometers at r + d_y, r + d_z
            d_y, d_z = (np.array(v, float) for v in extra["size_effect"])
            f_y = f_B + lever_arm_force(table, sched, tt, w_LB_B, r + d_y, extra)
            f_z = f_B + lever_arm_force(table, sched, tt, w_LB_B, r + d_z, extra)
            ra = accel.reading_at_points(f_x, f_y, f_z).reshape(-1, len(offs), 3)
        else:
            ra = accel.reading(f_x).reshape(-1, len(offs), 3)
        rg = gyro.reading(w_IB_B).reshape(-1, len(offs), 3)
        dv[a:a + chunk] = np.einsum("nkj,k->nj", ra, wts)
        dth[a:a + chunk] = np.einsum("nkj,k->nj", rg, wts)
    return dth, dv


def write_case(out, spec):
    rng = np.random.default_rng(spec.get("seed", 7))
    kind = spec["kind"]
    lat, hgt = spec.get("lat_deg", 48.1), spec.get("height_m", 520.0)
    g = normal_gravity(lat * DEG, hgt)
    w_ie_L = EARTH_RATE * np.array([0.0, np.cos(lat * DEG), np.sin(lat * DEG)])
    errs = spec["table_errors"]
    table = Table(kind, spec.get("heading_deg", 90.0), **errs)
    if spec.get("graded"):  # accel 30-300 ug, gyro 0.01-0.1 deg/h
        accel = graded_triad(rng, (30 * 9.80665e-6, 300 * 9.80665e-6))
        gyro = graded_triad(rng, (0.01 * DEG / 3600, 0.1 * DEG / 3600))
    else:
        accel = random_triad(rng, 500.0, 1e-3, 2e-4)
        gyro = random_triad(rng, 300.0, 5e-7, 2e-4)
    if "noise_seed" in spec:  # the same IMU (drawn above), another noise realisation
        rng = np.random.default_rng(spec["noise_seed"])
    sched = Schedule(table.naxes, spec.get("t0", 1000.0))
    spec["schedule"](sched, spec)
    rate = spec["rate_hz"]
    dt = 1.0 / rate
    n = int((sched.t - sched.steps[0][0]) * rate)
    t_end = sched.steps[0][0] + dt * np.arange(1, n + 1)
    dth, dv = integrate_increments(table, sched, accel, gyro, g, w_ie_L, t_end, dt,
                                   sub=spec.get("quad_sub", 2), extra=spec.get("extra"))
    if spec.get("noise", True):
        # white noise inside the sensor equation: diag(scale) * noise, integrated
        # default 3e-5 m/s/sqrt(s), 1e-6 rad/sqrt(s); spec noise_density overrides
        na, ng = spec.get("noise_density", (3e-5, 1e-6))
        dv += rng.normal(0, na * np.sqrt(dt), (n, 3)) * accel.scale
        dth += rng.normal(0, ng * np.sqrt(dt), (n, 3)) * gyro.scale
    if "quantum" in spec:  # quantised outputs with the remainder carried (counting sensors)
        qa, qg = spec["quantum"]
        dv = np.diff(np.round(np.cumsum(dv, axis=0) / qa), axis=0, prepend=0.0) * qa
        dth = np.diff(np.round(np.cumsum(dth, axis=0) / qg), axis=0, prepend=0.0) * qg
    for a, b in spec.get("swap", []):  # columns swapped under a correct header
        cols = {"dthx": (dth, 0), "dthy": (dth, 1), "dthz": (dth, 2), "dvx": (dv, 0), "dvy": (dv, 1), "dvz": (dv, 2)}
        (ma, ia), (mb, ib) = cols[a], cols[b]
        tmp = ma[:, ia].copy()
        ma[:, ia] = mb[:, ib]
        mb[:, ib] = tmp
    os.makedirs(out, exist_ok=True)
    meta = {"format": "imubench-csv/1", "site": {"latitude_deg": lat, "height_m": hgt},
            "imu": {"serial": "indep-" + spec["name"], "rate_hz": rate}, "table": {"kind": kind}}
    if kind == "two-axis":
        meta["table"]["outer_axis_heading_deg"] = spec.get("heading_deg", 90.0)
    with open(os.path.join(out, "meta.json"), "w") as f:
        json.dump(meta, f, indent=1)
    with open(os.path.join(out, "imu.csv"), "w") as f:
        f.write("t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n")
        data = np.column_stack([t_end, dth, dv])
        np.savetxt(f, data, fmt=["%.6f"] + ["%.12e"] * 6, delimiter=",", newline=",\n")
    # encoders: their own clock and rate, offset from the IMU's
    trate = spec.get("table_rate_hz", 50.0)
    tt = np.arange(sched.steps[0][0] + 0.0037, sched.t, 1.0 / trate)
    q, _ = sched.state(tt)
    header = "t,outer,inner" if kind == "two-axis" else "t,outer,middle,inner"
    np.savetxt(os.path.join(out, "table.csv"), np.column_stack([tt, q / DEG]),
               fmt=["%.6f"] + ["%.10f"] * table.naxes, delimiter=",", header=header, comments="")
    write_segments(out, sched, spec)
    truth = {"accel": accel.json(), "gyro": gyro.json(),
             "table": {"base_tilt": list(table.theta), "nonorthogonality": list(table.nu),
                       "mounting": list(table.mu), "encoder_zero": list(table.zero[: table.naxes])}}
    if spec.get("extra"):
        truth["extra"] = {k: extra_json(k, v) for k, v in spec["extra"].items()}
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)
    return truth


def extra_json(effect, v):
    """An effect of the spec in interchange.md's parameter names."""
    if effect == "lever_arm":
        return {"r_m": list(v)}
    if effect == "size_effect":
        return {"d_y_m": list(v[0]), "d_z_m": list(v[1])}
    if effect == "angle_harmonic":
        return {"axis": v[0], "order": v[1], "cos_rad": v[2], "sin_rad": v[3]}
    return {"tau_s": v}


def write_segments(out, sched, spec):
    """segments.csv: 'hold' one static per hold, 'settle+hold' a short settle and the hold
    proper, 'none' no file (derived from the encoders). An explicit settle step of the schedule
    (Schedule.settle) is written as its own segment of kind spec["settle_kind"] (interchange.md
    has no settle kind: "static" -- the table is at its target --, or "move" -- it still
    moves); with 'hold' it is part of the static that follows it."""
    mode = spec.get("segments", "settle+hold")
    if mode == "none":
        return
    rows = []
    for k, (t0, t1, axis, *_rest) in enumerate(sched.steps):
        kind = sched.kinds[k]
        if kind == "settle":
            if mode == "hold":
                rows.append((t0, t1, "static", "hold-%d" % k))
            else:
                rows.append((t0, t1, spec.get("settle_kind", "static"), "settle-%d" % k))
        elif axis >= 0:
            rows.append((t0, t1, "rotate", "run-%d" % k))
        elif mode == "settle+hold" and t1 - t0 > 4.0 and spec.get("split_holds", True):
            rows.append((t0, t0 + 2.0, "static", "settle-%d" % k))
            rows.append((t0 + 2.0, t1, "static", "hold-%d" % k))
        elif mode == "hold" and k > 0 and sched.kinds[k - 1] == "settle":
            rows[-1] = (rows[-1][0], t1, "static", rows[-1][3])  # settle + hold: one static
        else:
            rows.append((t0, t1, "static", "hold-%d" % k))
    with open(os.path.join(out, "segments.csv"), "w") as f:
        f.write("t0,t1,kind,label\n")
        for r in rows:
            f.write("%.6f,%.6f,%s,%s\n" % r)


# ---- schedules ----

def two_axis_combined(s, spec):
    """Direct positions (outer, inner in 0/90/180/270: every body axis up and down) and
    navigation runs (180-degree reversals about horizontal axes, full turns) in one recording."""
    H, q = spec.get("hold_s", 14.0), spec.get("quarter_deg", 90.0)
    s.hold(H)
    for axis, d in [(0, 4 * q), (0, -4 * q), (1, 4 * q), (1, -4 * q), (0, 2 * q), (0, -2 * q)]:
        s.move(axis, d)
        s.hold(H)
    for o in range(4):
        for i in range(4):
            s.move(1, q)
            s.hold(H)
            if o == 0 and i == 0:  # inner at 90: outer reversals about body -y
                for d in (2 * q, -2 * q, 4 * q, -4 * q):
                    s.move(0, d)
                    s.hold(H)
            if o == 1 and i == 1:  # platform vertical: inner reversals about a horizontal axis
                for d in (2 * q, -2 * q):
                    s.move(1, d)
                    s.hold(H)
        s.move(0, q)
        s.hold(H)


def single_orientation(s, spec):
    s.hold(300.0)


def three_axis_combined(s, spec):
    """Statics at five middle tilts and four inner angles, 180-degree reversals about the middle
    and inner axes, a rate ladder about the vertical outer axis with each body axis up."""
    H, q = spec.get("hold_s", 14.0), spec.get("quarter_deg", 90.0)
    OUT, MID, INN = 0, 1, 2
    s.hold(H)
    for m in range(4):
        for i in range(4):
            if i in (0, 1) and m in (0, 1):
                for d in (2 * q, -2 * q):  # middle reversals (about body x, then body y)
                    s.move(MID, d)
                    s.hold(H)
            if i in (0, 1) and m in (0, 1):  # rate ladder about the outer axis
                for rate, d in ((10.0, 4 * q), (10.0, -4 * q), (40.0, 8 * q), (40.0, -8 * q)):
                    s.move(OUT, d, rate_dps=rate, ramp_s=2.0)
                    s.hold(H)
            s.move(INN, q)
            s.hold(H)
            if m == 1 and i == 0:
                for d in (2 * q, -2 * q):  # inner reversals about a horizontal axis
                    s.move(INN, d)
                    s.hold(H)
        s.move(MID, q)
        s.hold(H)
        if spec.get("outer_positions", True):  # the outer angle varied: base tilt vs nu1
            s.move(OUT, q)
            s.hold(H)
    s.move(MID, q / 2)  # fifth tilt: 45 degrees
    for i in range(4):
        s.hold(H)
        s.move(INN, q)
    s.hold(H)


class Placer:
    """Moves a three-axis table to (outer, middle, inner) one axis at a time, each move followed
    by a settle (spec settle_s, 0: none; servo_arcsec: its decaying oscillation) and a hold."""

    def __init__(self, s, spec):
        self.s, self.spec = s, spec
        self.hold_s = spec.get("hold_s", 12.0)
        self.settle_s = spec.get("settle_s", 2.0)
        self.servo = spec.get("servo_arcsec", 0.0) * ARCSEC

    def rest(self, hold=True):
        if self.settle_s > 0:  # no oscillation before the first move
            self.s.settle(self.settle_s, self.servo if self.s.steps else 0.0)
        if hold:
            self.s.hold(self.hold_s)

    def turn(self, axis, deg, rate_dps=20.0, hold=True):
        self.s.move(axis, deg, rate_dps=rate_dps)
        self.rest(hold)

    def goto(self, target_deg):
        for axis in range(3):
            d = target_deg[axis] - self.s.q[axis] / DEG
            if abs(d) > 1e-9:
                self.turn(axis, d)

    def rate_pair(self):
        """Full turns about the vertical outer axis, both ways (gyro scale and the rate-run
        misalignments of the body axis that points up). spec runs_after_settle: the second turn
        follows the first after the settle only (a continuous test flow, no hold between)."""
        self.turn(0, 360.0, hold=not self.spec.get("runs_after_settle", False))
        self.turn(0, -360.0)

    def reversal(self, axis):
        """180 degrees about a horizontal table axis and back (a body axis turned end over end
        about itself: the navigation-based calibration's run)."""
        self.turn(axis, 180.0)
        self.turn(axis, -180.0)


def three_axis_natural(s, spec):
    """The natural three-axis calibration schedule, written from the physics (not copied from
    plans/library): C_LB = Rz(outer) Rx(middle) Rz(inner).
      statics with each body axis up and down: z up (0, 0, 0), z down (0, 180, 0), y up
      (0, 90, 0), y down (0, 90, 180), x up (0, 90, 90), x down (0, 90, 270), and z up at the
      four outer angles (base tilt against nu1, which turns with the outer axis);
      rate runs: a full turn each way about the vertical outer axis with each body axis up and
      down (the direct calibration's gyro scales and rate-run misalignments);
      180-degree reversals about each horizontal body axis at two headings of the horizontal
      table axis (outer 0 and 90: two Earth-rate projections): x_B about the middle axis
      (inner 0), y_B about the middle axis (inner 90), z_B about the inner axis (middle 90).
    Every move is followed by a settle and a hold (Placer)."""
    P = Placer(s, spec)
    MID, INN = 1, 2
    P.rest()  # z up
    P.rate_pair()
    for o in (0.0, 90.0):
        P.goto((o, 0.0, 0.0))
        P.reversal(MID)  # about x_B
        if o == 0.0:
            P.turn(MID, 180.0)  # z down: rate runs
            P.rate_pair()
            P.turn(MID, -180.0)
        P.goto((o, 0.0, 90.0))
        P.reversal(MID)  # about y_B
    for o in (180.0, 270.0):
        P.goto((o, 0.0, 90.0))
    P.goto((0.0, 0.0, 0.0))
    for o in (0.0, 90.0):
        P.goto((o, 90.0, 0.0))  # y up
        P.reversal(INN)  # about z_B
    P.goto((0.0, 90.0, 0.0))
    for i in (0.0, 90.0, 180.0, 270.0):  # y up, x up, y down, x down
        P.goto((0.0, 90.0, i))
        P.rate_pair()
    P.goto((0.0, 0.0, 0.0))


# ---- plan files (docs/plan-format.md): the writer's own reading of a plan's steps ----

UNITS = {"deg": DEG, "rad": 1.0, "arcsec": ARCSEC, "deg/s": DEG, "rad/s": 1.0,
         "deg/h": DEG / 3600.0, "deg/s^2": DEG, "rad/s^2": 1.0, "s": 1.0, "ms": 1e-3,
         "min": 60.0, "h": 3600.0}


def quantity(text):
    """'10 deg/s' -> SI (rad/s); the plan's units are mandatory (docs/plan-format.md)."""
    value, unit = text.split()
    return float(value) * UNITS[unit]


class PlanAxes:
    """Per-axis limits of a plan's [table]: max_rate, max_accel (the table's, overridden by
    [table.AXIS]), and min_angle/max_angle (both given: a limited axis)."""

    def __init__(self, table):
        self.names = ["outer", "inner"] if table["kind"] == "two-axis" else ["outer", "middle",
                                                                             "inner"]
        self.rate, self.accel, self.limited = [], [], []
        for n in self.names:
            ax = table.get(n, {})
            self.rate.append(quantity(ax.get("max_rate", table.get("max_rate"))))
            self.accel.append(quantity(ax.get("max_accel", table.get("max_accel"))))
            self.limited.append("min_angle" in ax and "max_angle" in ax)


def cosine_leg(axis, delta, rate, accel, flat_extra_s=0.0):
    """One axis' turn by delta (rad) with the cosine-ramp profile (ramp_profile) at most `rate`
    and peak acceleration at most `accel`: ramp time Tr = pi w / (2 accel); a turn too short to
    reach `rate` peaks lower. flat_extra_s: time at the rate on top of the turn's own (none for
    a turn of a given angle)."""
    dist = abs(delta)
    if dist == 0.0:
        return (axis, 0.0, 0.0, 0.0, 0.0)  # dropped by Schedule.motion
    w = min(rate, np.sqrt(2.0 * accel * dist / np.pi))
    Tr = np.pi * w / (2.0 * accel)
    flat = (dist - w * Tr) / w + flat_extra_s
    return (axis, delta, w, Tr, max(flat, 0.0))


def signed_step_value(step, key):
    v = quantity(step[key])
    d = step.get("direction")
    if d is not None:
        v = abs(v) * (1.0 if d in ("+", "ccw") else -1.0)
    return v


def plan_step(s, axes, step):
    """Append one plan step (docs/plan-format.md semantics) to the schedule s."""
    kind = step["type"]
    if kind == "hold":
        s.hold(quantity(step["duration"]))
    elif kind == "repeat":
        for _ in range(int(step["count"])):
            for sub in step["steps"]:
                plan_step(s, axes, sub)
    elif kind == "record":
        if step["state"] != "on":
            raise ValueError("write_recording.py: 'record off' spans are not written (a "
                             "recording with gaps)")
    elif kind in ("move", "rotate", "rate"):
        legs = []
        for j, name in enumerate(axes.names):
            if kind == "move" and name not in step:
                continue
            if kind != "move" and step["axis"] != name:
                continue
            rate = min(quantity(step["rate"]) if "rate" in step else axes.rate[j], axes.rate[j])
            rate = abs(rate)
            accel = quantity(step["accel"]) if "accel" in step else axes.accel[j]
            if kind == "move":  # absolute target: shortest way (continuous), direct (limited)
                d = quantity(step[name]) - s.q[j]
                if not axes.limited[j]:
                    d = (d + np.pi) % (2 * np.pi) - np.pi
                legs.append(cosine_leg(j, d, rate, accel))
            elif kind == "rotate":
                legs.append(cosine_leg(j, signed_step_value(step, "angle"), rate, accel))
            else:  # rate run: the documented angle rate (duration + rate / accel); the ramps
                # are the writer's cosine ramps within accel, the time at the rate makes it up
                w = signed_step_value(step, "rate")
                dur = quantity(step["duration"])
                legs.append(cosine_leg(j, w * (dur + abs(w) / accel), abs(w), accel))
        s.motion(legs)
    else:
        raise ValueError("write_recording.py: plan step type '%s' is not written (no chamber or "
                         "thermal model in this writer)" % kind)


def plan_schedule(s, spec):
    """The schedule of the plan file spec["plan_file"] (read with tomllib)."""
    axes = PlanAxes(spec["plan"]["table"])
    for step in spec["plan"].get("step", []):
        plan_step(s, axes, step)


def with_plan(spec, plan_path, seed):
    """The case spec recording plan_path instead of its own schedule: the same IMU, table errors
    and extras, another noise seed (the IMU's coefficients are drawn first from the case's
    seed, then the noise: both the same IMU)."""
    import tomllib
    with open(plan_path, "rb") as f:
        plan = tomllib.load(f)
    table = plan["table"]
    if table["kind"] != spec["kind"]:
        raise ValueError("%s: a %s plan for a %s case" % (plan_path, table["kind"], spec["kind"]))
    if table["kind"] == "two-axis":
        heading = quantity(table.get("outer_axis_heading", "90 deg")) / DEG
        if abs(heading - spec.get("heading_deg", 90.0)) > 1e-9:
            raise ValueError("%s: outer_axis_heading %g deg, the case's bench %g deg" % (
                plan_path, heading, spec.get("heading_deg", 90.0)))
    return dict(spec, schedule=plan_schedule, plan=plan, noise_seed=seed)


def table_errors(kind, big_tilt=False):
    a = ARCSEC
    theta = (1.0 * DEG, -0.4 * DEG) if big_tilt else (35 * a, -22 * a)
    if kind == "two-axis":
        return {"theta": theta, "nu": (28 * a,), "mu": (-41 * a, 17 * a), "zero": (19 * a, -33 * a, 0.0)}
    return {"theta": theta, "nu": (24 * a, -47 * a, 31 * a), "mu": (-38 * a, 15 * a),
            "zero": (21 * a, 55 * a, -29 * a)}


def make_cases():
    def two(**kw):
        return {**dict(kind="two-axis", schedule=two_axis_combined, rate_hz=100.0,
                       table_errors=table_errors("two-axis")), **kw}

    def three(**kw):
        return {**dict(kind="three-axis", schedule=three_axis_combined, rate_hz=100.0,
                       table_errors=table_errors("three-axis")), **kw}
    c = {
        "two_100hz_settle_hold": two(),
        "two_400hz_hold": two(rate_hz=400.0, segments="hold", table_rate_hz=100.0),
        "two_derived_segments": two(segments="none"),
        "two_noise_free": two(noise=False),
        "two_quantised": two(noise=False, quantum=(1e-5, 1e-8)),
        "two_tilt_1deg": two(table_errors=table_errors("two-axis", big_tilt=True)),
        "two_heading_91": two(heading_deg=91.0),
        "two_quarter_89.99999985": two(quarter_deg=89.99999985),
        "two_single_orientation": two(schedule=single_orientation),
        "two_swapped_gyro_xy": two(swap=[("dthx", "dthy")]),
        "two_swapped_accel_xz": two(swap=[("dvx", "dvz")]),
        "three_100hz_settle_hold": three(),
        "three_derived_segments": three(segments="none"),
        "three_outer_fixed": three(outer_positions=False),
    }
    for name, spec in c.items():
        spec["name"] = name
    return c


# Navigation-grade white noise: velocity random walk 10 ug/sqrt(Hz) (1e-4 m/s/sqrt(s)), angle
# random walk 0.002 deg/sqrt(h) (5.8e-7 rad/sqrt(s)).
NAV_NOISE = (1.0e-4, 0.002 * DEG / 60.0)


def three_axis_errors(tilt_deg=None):
    """20-60 arcsec on every geometric term of the three-axis chain (interchange.md): base tilt
    (theta_x, theta_y), nu1 (x, y), nu2_y, mounting (x, y), encoder zeros (outer, middle,
    inner); tilt_deg: the base tilt in degrees instead."""
    a = ARCSEC
    theta = (tilt_deg[0] * DEG, tilt_deg[1] * DEG) if tilt_deg else (-27 * a, 44 * a)
    return {"theta": theta, "nu": (52 * a, -33 * a, 41 * a), "mu": (29 * a, -57 * a),
            "zero": (-46 * a, 38 * a, 23 * a)}


def make_calibrate_cases():
    """Three-axis recordings with realistic table and IMU errors on the natural schedule
    (three_axis_natural), for calibrate_cases.py, and the variants that locate a refusal."""
    def nat(**kw):
        return {**dict(kind="three-axis", schedule=three_axis_natural, rate_hz=100.0,
                       table_errors=three_axis_errors(), graded=True, noise_density=NAV_NOISE,
                       seed=31, split_holds=False), **kw}
    c = {
        "nat3_100hz": nat(),
        # 3 quadrature nodes per 2.5 ms sample: the motion is smooth on that scale
        "nat3_400hz": nat(seed=32, rate_hz=400.0, table_rate_hz=100.0, quad_sub=1),
        "nat3_tilt_1deg": nat(seed=33, table_errors=three_axis_errors(tilt_deg=(0.8, -0.6))),
        "nat3_servo": nat(seed=34, servo_arcsec=25.0),
        "nat3_servo_move": nat(seed=34, servo_arcsec=25.0, settle_kind="move"),
        # a servo oscillation beyond the segment check's still span: the settle moves
        "nat3_servo_45": nat(seed=34, servo_arcsec=45.0),
        "nat3_runs_after_settle": nat(seed=35, runs_after_settle=True),
        # diagnosis variants (calibrate_cases.py --diagnose)
        "nat3_no_settle": nat(settle_s=0.0, hold_s=14.0),
        "nat3_settle_in_hold": nat(segments="hold"),
        "nat3_zero_table": nat(table_errors={}),
        "nat3_derived_segments": nat(segments="none"),
    }
    for name, spec in c.items():
        spec["name"] = name
    return c


def make_explain_cases():
    """Recordings with physics the calibration model lacks, for `imubench explain`
    (explain_cases.py): the two-axis combined schedule at other rates than ours."""
    def two(**kw):
        return {**dict(kind="two-axis", schedule=two_axis_combined, rate_hz=100.0,
                       table_errors=table_errors("two-axis")), **kw}
    c = {
        "explain_clean": two(seed=11),
        "explain_lever_arm": two(seed=12, rate_hz=125.0, extra={"lever_arm": (0.05, -0.03, 0.04)}),
        "explain_time_delay": two(seed=13, rate_hz=200.0, extra={"time_delay": 0.003}),
        # an elliptic inner encoder (order 2), 15 arcsec
        "explain_angle_harmonic": two(seed=14, rate_hz=100.0, table_rate_hz=40.0,
                                      extra={"angle_harmonic": ("inner", 2, 6.0e-5, -4.5e-5)}),
    }
    for name, spec in c.items():
        spec["name"] = name
    return c


def one_axis_only(axis, turn_deg, ramp_s):
    """A poor schedule turning one two-axis table axis only: holds at eight angles of it 45
    degrees apart, then a turn of turn_deg each way at 30 deg/s (ramps ramp_s).
      axis 1 (inner; outer at 0, inner axis vertical): a level recording. A base tilt about the
        outer axis' perpendicular and the inner axis' nonorthogonality tilt the inner axis the
        same way; the x and y accelerometers never see gravity along them.
      axis 0 (outer; inner at 0, x_B along the horizontal outer axis): every rotation is about
        x_B, and the centripetal force a lever arm and the accelerometers' own positions add is
        -w^2 (0, y, z) of the point: the y accelerometer's y offset and the z accelerometer's z
        offset act as the lever arm's y and z."""
    def schedule(s, spec):
        H = spec.get("hold_s", 50.0)
        for _ in range(8):
            s.hold(H)
            s.move(axis, 45.0, rate_dps=10.0)
        s.hold(H)
        for d in (turn_deg, -turn_deg):
            s.move(axis, d, rate_dps=30.0, ramp_s=ramp_s)
            s.hold(H)
    return schedule


def three_axis_outer_fixed(s, spec):
    """A poor three-axis schedule: the vertical outer axis never turns. Holds with each body axis
    up and down (middle 0 and 180; middle 90 at four inner angles), turns about the inner and
    middle axes each way. A base tilt, the middle axis' nonorthogonality nu1 and the middle
    encoder zero then all tilt the middle axis alike: they are told apart only when the outer
    axis turns (nu1 and the middle zero turn with it, the base tilt does not)."""
    H, OUT, MID, INN = spec.get("hold_s", 40.0), 0, 1, 2
    s.hold(H)
    s.move(INN, 360.0)
    s.hold(H)
    s.move(MID, 180.0)
    s.hold(H)
    s.move(MID, -90.0)
    for _ in range(4):
        s.hold(H)
        s.move(INN, 90.0)
    s.hold(H)
    s.move(MID, -360.0)
    s.hold(H)
    s.move(INN, -360.0)
    s.hold(H)
    assert OUT == 0


def make_propose_cases():
    """Recordings A whose motion leaves a pair of effects concealed (propose_cases.py): explain
    proposes the plan, the writer records it (--plan) with the same IMU and truth."""
    a = ARCSEC
    level_errors = {"theta": (0.0, -20 * a), "nu": (30 * a,), "mu": (0.0, 0.0), "zero": (0, 0, 0)}

    def lvl(**kw):
        return {**dict(kind="two-axis", schedule=one_axis_only(1, 360.0, 2.0), rate_hz=100.0,
                       graded=True, noise_density=NAV_NOISE, table_errors=level_errors), **kw}
    c = {
        "pair_level_tilt_nonorth": lvl(seed=41),
        "pair_outer_lever_size": lvl(
            seed=42, schedule=one_axis_only(0, 1080.0, 3.0), table_errors=table_errors("two-axis"),
            extra={"lever_arm": (0.05, -0.03, 0.04),
                   "size_effect": ((0.01, 0.02, -0.01), (-0.02, 0.01, 0.015))}),
        "pair_three_outer_fixed": lvl(
            seed=43, kind="three-axis", schedule=three_axis_outer_fixed,
            table_errors=three_axis_errors(),
            extra={"lever_arm": (0.04, 0.03, -0.05),
                   "size_effect": ((0.015, -0.01, 0.02), (0.01, 0.02, -0.015))}),
    }
    for name, spec in c.items():
        spec["name"] = name
    return c


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out")
    cases = {**make_cases(), **make_explain_cases(), **make_calibrate_cases(),
             **make_propose_cases()}
    ap.add_argument("--case", required=True, choices=sorted(cases))
    ap.add_argument("--plan", help="record this plan file (docs/plan-format.md) instead of the "
                    "case's schedule: the case's IMU, table errors and extras")
    ap.add_argument("--seed", type=int, default=1001, help="noise seed with --plan")
    args = ap.parse_args()
    spec = cases[args.case]
    if args.plan:
        spec = with_plan(spec, args.plan, args.seed)
    write_case(args.out, spec)


if __name__ == "__main__":
    main()
