#!/usr/bin/env python3
"""Independent thermal recordings: the writer's table, schedule and integration
(write_recording.py, interchange.md only) with a sensor whose coefficients follow an
imubench-thermal/1 truth (interchange.md "Thermal compensation file"):

    c(T, Tdot) = sum_k poly[k] (T - t_ref_c)^k + dTdt * Tdot

for every scale, bias and misalignment of both triads, T the IMU temperature (the imu.csv temp
column), Tdot its rate. The true inputs are integrated over each sample interval by the
writer's quadrature (an ideal triad), then read through eq. 1 with the coefficients at the
interval's temperature and rate (they change by far less than the noise within one interval):
    increment = diag(scale) (M dinput - bias dt + noise).

Sets (the calibration body: write_recording.two_axis_combined, 20-60 arcsec on every
geometric term of a two-axis table):
  ramp  one recording, the chamber cycling 10 -> 40 -> 10 degC (T = 25 - 15 cos(2 pi t / P)):
        heating and cooling, so the bias hysteresis (dT/dt term) is seen;
  soak  one recording per soak point (-40, -20, 0, 20, 40, 60 degC; one body each), the IMU
        at rest at the setpoint, and one at 30 degC held out of the fit (two bodies).
Truth: cubic biases, linear scales, bias hysteresis, constant misalignments
(thermal_truth.json); the table in truth.json (coefficient-file "table" section).

Usage: write_thermal.py OUT_DIR --set ramp|soak
"""
import argparse
import json
import os

import numpy as np

import write_recording as wr

UG = 9.80665e-6  # m/s^2
DEG_H = np.pi / 180.0 / 3600.0  # rad/s
PPM = 1e-6
T_REF = 20.0
MIS_KEYS = ["xy", "xz", "yx", "yz", "zx", "zy"]
SOAK_POINTS = [-40.0, -20.0, 0.0, 20.0, 40.0, 60.0]
HELD_OUT = 30.0


def table_errors(kind="two-axis"):
    """20-60 arcsec on every geometric term of a two- or three-axis table."""
    a = wr.ARCSEC
    if kind == "three-axis":
        return {"theta": (35 * a, -48 * a), "nu": (24 * a, -47 * a, 31 * a),
                "mu": (-41 * a, 24 * a), "zero": (21 * a, 55 * a, -29 * a)}
    return {"theta": (35 * a, -48 * a), "nu": (52 * a,), "mu": (-41 * a, 24 * a),
            "zero": (27 * a, -33 * a, 0.0)}


def P(poly, h=None):
    p = {"poly": [float(c) for c in poly]}
    if h is not None:
        p["dTdt"] = float(h)
    return p


def thermal_truth(rng):
    """Cubic biases with hysteresis, linear scales, constant misalignments (SI)."""
    def triad(c0_bias, c1, c2, c3, h, s0_ppm, s1_ppm, mis):
        return {"scale": [P([1 + s0_ppm[i] * PPM, s1_ppm[i] * PPM]) for i in range(3)],
                "bias": [P([c0_bias[i], c1[i], c2[i], c3[i]], h[i]) for i in range(3)],
                "misalignment": {k: P([float(rng.uniform(-mis, mis))]) for k in MIS_KEYS}}
    accel = triad(np.array([400.0, -250.0, 320.0]) * UG, np.array([5.0, -4.0, 3.0]) * UG,
                  np.array([0.05, -0.03, 0.04]) * UG, np.array([2e-3, -1.5e-3, 1.2e-3]) * UG,
                  np.array([0.8, -0.6, 0.7]) * UG / 1e-3,  # 0.8 ug per mK/s
                  [300.0, -200.0, 150.0], [20.0, -15.0, 10.0], 2e-4)
    gyro = triad(np.array([0.5, -0.3, 0.4]) * DEG_H, np.array([0.05, -0.04, 0.03]) * DEG_H,
                 np.array([1e-3, -7.5e-4, 5e-4]) * DEG_H, np.array([5e-5, -4e-5, 4.5e-5]) * DEG_H,
                 np.array([0.025, -0.02, 0.03]) * DEG_H / 1e-3,  # 0.025 deg/h per mK/s
                 [100.0, -80.0, 60.0], [30.0, -20.0, 25.0], 2e-4)
    return {"format": "imubench-thermal/1", "imu": {"serial": "indep-thermal"}, "t_ref_c": T_REF,
            "range_c": [-40.0, 60.0], "accel": accel, "gyro": gyro}


def coefficient(p, dT, Tdot):
    return sum(c * dT**k for k, c in enumerate(p["poly"])) + p.get("dTdt", 0.0) * Tdot


def triad_at(tr, dT, Tdot):
    """scale (n,3), bias (n,3), M (n,3,3) of an imubench-thermal/1 triad at (T, Tdot) arrays."""
    scale = np.stack([coefficient(p, dT, Tdot) for p in tr["scale"]], axis=1)
    bias = np.stack([coefficient(p, dT, Tdot) for p in tr["bias"]], axis=1)
    m = {k: coefficient(tr["misalignment"][k], dT, Tdot) for k in MIS_KEYS}
    one, n = np.ones_like(dT), dT.shape[0]
    M = np.empty((n, 3, 3))
    M[:, 0] = np.stack([one, m["xy"], -m["xz"]], axis=1)
    M[:, 1] = np.stack([-m["yx"], one, m["yz"]], axis=1)
    M[:, 2] = np.stack([m["zx"], -m["zy"], one], axis=1)
    return scale, bias, M


def body(sched, dur, kind="two-axis"):
    """The calibration body repeated until at least dur seconds are scheduled."""
    make = wr.two_axis_combined if kind == "two-axis" else wr.three_axis_combined
    make(sched, {"hold_s": 14.0})
    while sched.t - sched.steps[0][0] < dur:
        make(sched, {"hold_s": 14.0})


def write_thermal_case(out, name, temp_fn, dur, truth, seed, rate=25.0, kind="two-axis"):
    """One recording: temp_fn(t) -> (T, Tdot) of the IMU; the body for >= dur seconds."""
    rng = np.random.default_rng(seed)
    lat, hgt = 48.1, 520.0
    g = wr.normal_gravity(lat * wr.DEG, hgt)
    w_ie_L = wr.EARTH_RATE * np.array([0.0, np.cos(lat * wr.DEG), np.sin(lat * wr.DEG)])
    table = wr.Table(kind, 90.0, **table_errors(kind))
    sched = wr.Schedule(table.naxes, 1000.0)
    body(sched, dur, kind)
    dt = 1.0 / rate
    n = int((sched.t - sched.steps[0][0]) * rate)
    t_end = sched.steps[0][0] + dt * np.arange(1, n + 1)
    ideal = wr.Triad([1, 1, 1], [0, 0, 0], {k: 0.0 for k in MIS_KEYS})
    dth_in, dv_in = wr.integrate_increments(table, sched, ideal, ideal, g, w_ie_L, t_end, dt)
    T, Tdot = temp_fn(t_end - dt / 2)
    dT = T - truth["t_ref_c"]
    out_inc = []
    for key, inc, sigma in (("gyro", dth_in, 1e-6), ("accel", dv_in, 3e-5)):
        scale, bias, M = triad_at(truth[key], dT, Tdot)
        noise = rng.normal(0, sigma * np.sqrt(dt), (n, 3))
        out_inc.append(scale * (np.einsum("nij,nj->ni", M, inc) - bias * dt + noise))
    dth, dv = out_inc
    os.makedirs(out, exist_ok=True)
    meta = {"format": "imubench-csv/1", "site": {"latitude_deg": lat, "height_m": hgt},
            "imu": {"serial": truth["imu"]["serial"], "rate_hz": rate},
            "table": {"kind": kind}}
    if kind == "two-axis":
        meta["table"]["outer_axis_heading_deg"] = 90.0
    with open(os.path.join(out, "meta.json"), "w") as f:
        json.dump(meta, f, indent=1)
    temp = np.round(T, 3)  # a 1 mK temperature sensor
    np.savetxt(os.path.join(out, "imu.csv"), np.column_stack([t_end, dth, dv, temp]),
               fmt=["%.6f"] + ["%.12e"] * 6 + ["%.3f"], delimiter=",",
               header="t,dthx,dthy,dthz,dvx,dvy,dvz,temp", comments="")
    tt = np.arange(sched.steps[0][0] + 0.0037, sched.t, 0.1)  # encoders at 10 Hz
    q, _ = sched.state(tt)
    np.savetxt(os.path.join(out, "table.csv"), np.column_stack([tt, q / wr.DEG]),
               fmt=["%.6f"] + ["%.10f"] * table.naxes, delimiter=",",
               header="t,outer,inner" if kind == "two-axis" else "t,outer,middle,inner",
               comments="")
    wr.write_segments(out, sched, {"segments": "settle+hold"})
    e = table_errors(kind)
    tab = {"base_tilt": list(e["theta"]), "nonorthogonality": list(e["nu"]),
           "mounting": list(e["mu"]), "encoder_zero": list(e["zero"][:table.naxes])}
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump({"table": tab}, f, indent=1)
    with open(os.path.join(out, "thermal_truth.json"), "w") as f:
        json.dump(truth, f, indent=1)


def ramp_temperature(period):
    w = 2 * np.pi / period
    return lambda t: (25.0 - 15.0 * np.cos(w * (t - 1000.0)), 15.0 * w * np.sin(w * (t - 1000.0)))


def soak_temperature(setpoint):
    return lambda t: (np.full_like(t, setpoint), np.zeros_like(t))


def write_set(out, which):
    """ramp: OUT/ramp; soak: OUT/soak_<T> per soak point and OUT/heldout_<T>."""
    truth = thermal_truth(np.random.default_rng(5))
    if which == "ramp":
        write_thermal_case(os.path.join(out, "ramp"), "ramp", ramp_temperature(2400.0), 2400.0,
                           truth, seed=21)
        return
    for k, sp in enumerate(SOAK_POINTS + [HELD_OUT]):
        name = ("heldout_%g" if sp == HELD_OUT else "soak_%g") % sp
        # the held-out point: two bodies, so its residual statistic is tight (66 holds)
        write_thermal_case(os.path.join(out, name), name, soak_temperature(sp),
                           1000.0 if sp == HELD_OUT else 1.0, truth, seed=31 + k)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out")
    ap.add_argument("--set", required=True, choices=["ramp", "soak"])
    args = ap.parse_args()
    write_set(args.out, args.set)


if __name__ == "__main__":
    main()
