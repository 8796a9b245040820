#!/usr/bin/env python3
"""Prints the side-by-side result of `bench/run.sh --against REV` (see there).

Arguments: the run's directory (files SIDE.TARGET.ROUND.json / .time, SIDE = this | rev), the
revision, the number of rounds, the target names. Per benchmark: the median over the rounds of
the CPU and wall time per iteration of both trees and their ratio REV/this (> 1: this tree is
faster); per target the peak RSS of both processes; and the ratio this/REV of every counter both
report (a rate: > 1 is faster; a time or a fraction: < 1 is faster).
"""
import json
import os
import statistics
import sys

_UNIT_S = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def _load(directory, side, target, rounds):
    """{benchmark name: {"cpu": [s], "real": [s], "counters": {name: [v]}}}, [peak RSS MiB]"""
    per_name = {}
    rss = []
    for r in range(1, rounds + 1):
        base = os.path.join(directory, f"{side}.{target}.{r}")
        try:
            with open(base + ".json", encoding="utf-8") as f:
                doc = json.load(f)
        except (OSError, ValueError):
            continue
        for b in doc.get("benchmarks", []):
            if b.get("run_type") == "aggregate" or "error_message" in b:
                continue
            unit = _UNIT_S.get(b.get("time_unit", "ns"), 1e-9)
            e = per_name.setdefault(b["name"], {"cpu": [], "real": [], "counters": {}})
            e["cpu"].append(b["cpu_time"] * unit)
            e["real"].append(b["real_time"] * unit)
            skip = {"name", "run_name", "run_type", "repetitions", "repetition_index",
                    "threads", "iterations", "real_time", "cpu_time", "time_unit",
                    "family_index", "per_family_instance_index", "aggregate_name"}
            for k, v in b.items():
                if k not in skip and isinstance(v, (int, float)):
                    e["counters"].setdefault(k, []).append(float(v))
        try:
            with open(base + ".time", encoding="utf-8") as f:
                fields = f.read().split()
            rss.append(float(fields[-1]) / 1024.0)
        except (OSError, ValueError, IndexError):
            pass
    return per_name, rss


def _fmt_s(s):
    if s >= 1.0:
        return f"{s:.3g} s"
    if s >= 1e-3:
        return f"{s * 1e3:.3g} ms"
    if s >= 1e-6:
        return f"{s * 1e6:.3g} us"
    return f"{s * 1e9:.3g} ns"


def main(argv):
    directory, rev, rounds, targets = argv[1], argv[2], int(argv[3]), argv[4:]
    print(f"== this tree vs {rev}: medians of {rounds} alternating rounds; "
          f"ratio = {rev} time / this time (> 1: this tree faster) ==")
    for target in targets:
        this, this_rss = _load(directory, "this", target, rounds)
        other, other_rss = _load(directory, "rev", target, rounds)
        print(f"-- {target}")
        if this_rss and other_rss:
            print(f"   peak RSS (process): this {max(this_rss):.0f} MiB, "
                  f"{rev} {max(other_rss):.0f} MiB")
        for name, e in this.items():
            o = other.get(name)
            if o is None:
                print(f"   {name}: only in this tree")
                continue
            tc, oc = statistics.median(e["cpu"]), statistics.median(o["cpu"])
            tr, orr = statistics.median(e["real"]), statistics.median(o["real"])
            print(f"   {name}: cpu {_fmt_s(tc)} vs {_fmt_s(oc)} ratio {oc / tc:.3f}; "
                  f"wall {_fmt_s(tr)} vs {_fmt_s(orr)} ratio {orr / tr:.3f}")
            for k, v in sorted(e["counters"].items()):
                ov = o["counters"].get(k)
                if not ov:
                    continue
                a, b = statistics.median(v), statistics.median(ov)
                ratio = f"{a / b:.3f}" if b else "-"
                print(f"      {k}: {a:.6g} vs {b:.6g} (this/{rev} {ratio})")
        for name in other:
            if name not in this:
                print(f"   {name}: only in {rev}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
