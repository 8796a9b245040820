#!/usr/bin/env python3
"""A lab script: the same plan at several chamber temperatures, one run per temperature.

For each temperature the plan template (default: thermal_point.toml beside this script) is
sent with its chamber step's setpoint replaced, labelled "T=+20C" etc.; the script waits for
the run to end and prints its results. The template must hold exactly one line
`setpoint = "... degC"` (its chamber step): that is the only thing changed, so the daemon's
plan checker still sees the plan as written (ramp limits, [chamber] range).

The plan is sent as TOML text ({"plan":{"toml":...}}), not as a temporary file: the daemon
runs as its own user with a private /tmp and would not see a file this script writes there.

    thermal_sweep.py --temps=-20,20,60 [--plan thermal_point.toml] [--socket PATH] [--dry-run]

Exit status: 0 when every run completed; 1 at the first run that did not (the sweep stops
there: the bench needs an operator); 2 for bad arguments.
"""

import argparse
import json
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import imubench_client  # noqa: E402  (tools/python, beside this directory)

SETPOINT = re.compile(r'^(\s*setpoint\s*=\s*)"[^"]*"', re.MULTILINE)


def plan_at(template, temp_c):
    """The template's text with its one chamber setpoint set to temp_c."""
    matches = SETPOINT.findall(template)
    if len(matches) != 1:
        raise ValueError("the plan template needs exactly one `setpoint = \"...\"` line (its "
                         "chamber step), found %d" % len(matches))
    return SETPOINT.sub(lambda m: '%s"%g degC"' % (m.group(1), temp_c), template)


def label_for(temp_c):
    return "T=%+gC" % temp_c


def parse_temps(text):
    try:
        temps = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError("temperatures: comma-separated degC, e.g. -20,20,60")
    if not temps:
        raise argparse.ArgumentTypeError("temperatures: at least one")
    return temps


def main(argv=None):
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--temps", type=parse_temps, default=[-20.0, 20.0, 60.0],
                    help="chamber setpoints in degC, comma-separated (default -20,20,60)")
    ap.add_argument("--plan", default=os.path.join(here, "thermal_point.toml"),
                    help="plan template with one chamber step")
    ap.add_argument("--socket", default=None, help="control socket (default $IMUBENCH_SOCKET "
                    "or " + imubench_client.DEFAULT_SOCKET + ")")
    ap.add_argument("--dry-run", action="store_true", help="validate each plan, move nothing")
    args = ap.parse_args(argv)

    with open(args.plan, encoding="utf-8") as f:
        template = f.read()
    try:
        plans = [(t, plan_at(template, t)) for t in args.temps]
    except ValueError as e:
        print("thermal_sweep: %s: %s" % (args.plan, e), file=sys.stderr)
        return 2

    try:
        with imubench_client.Client(args.socket) as client:
            for temp, plan in plans:
                label = label_for(temp)
                client.subscribe(("run", "status"))  # before start: no event is missed
                started = client.start(toml=plan, label=label, dry_run=args.dry_run)
                run = started.get("run")
                print("%s: started run %s" % (label, run if run is not None else "?"), flush=True)
                if args.dry_run:
                    continue

                def show(ev):
                    if ev.get("event") == "alarm":
                        print("  ALARM: %s" % ev.get("message", "?"), flush=True)
                    elif ev.get("event") == "step_started" and "label" in ev:
                        print("  step %s %s" % (ev.get("step", "?"), ev["label"]), flush=True)

                end = client.wait_finished(on_event=show)
                if not imubench_client.run_completed(end):
                    print("%s: run %s ended %s %s; sweep stopped" % (
                        label, run, end.get("state"), end.get("exit", "")), file=sys.stderr)
                    return 1
                print("%s: run %s completed" % (label, run), flush=True)
                results = client.results(run) if run is not None else client.results()
                print(json.dumps(results, indent=2, sort_keys=True), flush=True)
    except imubench_client.ControlError as e:
        print("thermal_sweep: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
