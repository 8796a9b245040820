"""Checks shared by the daemon's fault end-to-end tests (fault_*.sh, table_restart.sh): a fault
injected in the virtual bench mid-run must leave imubenchd up, stop motion, pause the plan with
an alarm on the control socket and in the log (the logger writes each line to syslog and, with
--stderr, to the daemon's output the harness keeps), keep recording what still arrives, and let
`resume` finish the plan once the device is back.

    from fault_checks import *
    c = start_smoke_run(work, plan)                 # subscribed to "run", into step r1
    alarm = wait_alarm(c, "IMU silent")             # the pause and its alarm
    motion_stopped(c)                                # the table at rest, angles unchanged
    alarm_logged(work, "IMU silent")
    resume_when_back(c, ...)                         # refused while the fault lasts
    recording_intact(work, cli, ...)                 # every step once, samples gap-free
"""
import os
import re
import subprocess
import time

from e2e_client import Client, check, plan_file, read_csv, start_run

IMU_PERIOD_S = 0.001  # navgrade_fd.toml: 1 kHz


def status(c):
    r = c.reply({"cmd": "status"})
    check(r["ok"], "status answers")
    return r["result"]


def timed_status(c):
    """The status reply and how long it took (wall s)."""
    t0 = time.monotonic()
    st = status(c)
    return st, time.monotonic() - t0


def start_smoke_run(work, plan, into="r1", after_s=0.5):
    """Starts the plan; returns once step `into` has run for after_s wall seconds."""
    c = start_run(work, plan)
    c.wait_event(lambda e: e["event"] == "step_started" and e["label"] == into, into + " start")
    time.sleep(after_s)
    return c


def wait_alarm(c, text, limit=30):
    """The run pauses and raises an alarm containing text (both on the socket)."""
    alarm = c.wait_event(lambda e: e["event"] == "alarm" and text in e["message"],
                         "alarm '%s'" % text, limit)
    c.wait_event(lambda e: e["event"] == "state" and e["state"] == "paused", "pause", limit)
    check(True, "alarm on the socket: " + alarm["message"])
    return alarm


def motion_stopped(c, limit=20):
    """The table comes to rest and stays there (same angles 1 s later)."""
    end = time.monotonic() + limit
    st = status(c)
    while time.monotonic() < end and st["table"].get("moving") is not False:
        time.sleep(0.1)
        st = status(c)
    check(st["table"].get("moving") is False, "the table comes to rest: %s" % st["table"])
    time.sleep(1.0)
    later = status(c)
    moved = max(abs(a - b) for a, b in zip(st["table"]["angles_deg"],
                                           later["table"]["angles_deg"]))
    # A table still turning at the plan's 10 deg/s would have moved 10 deg.
    check(later["table"]["moving"] is False and moved < 0.05 and later["state"] == "paused",
          "motion stopped, plan paused (moved %.4f deg in 1 s)" % moved)
    return later


def alarm_logged(work, text, limit=10):
    """The alarm in the daemon's log at warning level (what goes to syslog)."""
    pattern = re.compile(r"^imubenchd: warning: run \d+: ALARM: .*" + re.escape(text), re.M)
    end = time.monotonic() + limit
    while True:
        with open(os.path.join(work, "d.out")) as fh:
            m = pattern.search(fh.read())
        if m or time.monotonic() > end:
            break
        time.sleep(0.1)
    check(m is not None, "alarm in the log: %s" % (m.group(0) if m else text))


def resume_refused(c, text):
    r = c.reply({"cmd": "resume"})
    check(not r["ok"] and r["error"]["code"] == "bad_state" and text in r["error"]["message"],
          "resume refused while the fault lasts: %s" % r.get("error"))


def resume_when_back(c, limit=30):
    """Resume, retried (bounded) until the device is back; then the plan completes."""
    end = time.monotonic() + limit
    while True:
        r = c.reply({"cmd": "resume"})
        if r["ok"] or time.monotonic() > end:
            break
        check(r["error"]["code"] == "bad_state", "resume refused with a reason: %s" % r["error"])
        time.sleep(0.2)
    check(r["ok"], "resume once the device is back: %s" % r)
    fin = c.wait_event(lambda e: e["event"] == "run_finished" and e["run"] == c.run, "run end", 120)
    check(fin["state"] == "finished" and fin["exit"] == "completed", "the plan completed: %s" % fin)


def recording_intact(work, cli, run, labels, allowed_gap=None):
    """Exports the run: every step stored once; IMU sample times strictly increase without a
    gap, except inside allowed_gap = (t0, t1) (an IMU silence), as they arrived."""
    out = os.path.join(work, "export-%d" % run)
    p = subprocess.run([cli, "export", str(run), "--csv", out, "--db", work + "/imubench.db"],
                       capture_output=True, text=True, timeout=120)
    check(p.returncode == 0, "export: %s%s" % (p.stdout, p.stderr))
    segs = [s["label"] for s in read_csv(out + "/segments.csv")]
    check(segs == labels, "every step stored once: %s" % segs)
    t = [float(r["t"]) for r in read_csv(out + "/imu.csv")]
    check(all(b > a for a, b in zip(t, t[1:])), "IMU sample times strictly increase")
    gaps = [(a, b) for a, b in zip(t, t[1:]) if b - a > 2.5 * IMU_PERIOD_S]
    if allowed_gap is None:
        check(not gaps, "the IMU recording has no gap through the fault (%d samples)" % len(t))
    else:
        outside = [g for g in gaps if not (allowed_gap[0] - 0.5 <= g[0] and g[1] <= allowed_gap[1] + 0.5)]
        check(not outside, "gaps only while the IMU was silent: %s" % outside[:3])
    return t
