#!/usr/bin/env python3
"""Runs clang-tidy (the checks of the root .clang-tidy) over the project's changed sources.

Why changed sources only: clang-tidy 14 matches every check over the whole AST of a
translation unit, system headers included, so even a small TU that includes Eigen costs
10-15 s of CPU and a Ceres one up to 2 minutes; the whole tree (about 230 TUs) is an hour of
CPU, far beyond the minutes CI can spend (docs/ci.md has the measurements). So CI checks the
TUs whose code changed since the commit recorded in tools/tidy_base.txt (the diff of that
commit against the working tree, untracked sources included; a changed header is checked
through the TU of the same name, else through the including TU that includes the fewest files). Lines that only move
an #include (a file moved to another folder) do not count as a change. More than --max-tus
TUs fail rather than blowing the CI budget: check them locally (--all or FILEs) and advance
tools/tidy_base.txt. Findings count in the changed (or named) files only: a finding clang-tidy
reports in an unchanged project header that a checked TU includes is listed, not counted (it
is not the change's to fix; docs/ci.md lists the known ones).

Usage:
  tidy_check.py -p BUILD                 changed since tools/tidy_base.txt (what CI runs)
  tidy_check.py -p BUILD --base REV      changed since REV
  tidy_check.py -p BUILD --all           every TU of the compile database (slow)
  tidy_check.py -p BUILD FILE...         these files (headers through an including TU)
BUILD holds compile_commands.json (configure with -DCMAKE_EXPORT_COMPILE_COMMANDS=ON).
Exits 1 on any finding, naming FILE:LINE:COL, the message and the check.
"""
import argparse
import concurrent.futures
import json
import os
import re
import subprocess
import sys
import time

from function_size_check import EXCLUDED, SOURCE_DIRS  # the project's sources, once

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
INCLUDE_LINE = re.compile(r'^[+-]\s*#\s*include\b')


def fail(message):
    print("tidy_check: " + message, file=sys.stderr)
    sys.exit(1)


def git(root, *args):
    return subprocess.run(["git", "-C", root, *args], check=True, capture_output=True,
                          text=True).stdout


def ours(rel):
    return (rel.split("/")[0] in SOURCE_DIRS and rel.endswith((".h", ".cpp"))
            and rel not in EXCLUDED)


def changed_files(root, base):
    """Project sources whose code (not only their #include lines) differs between base and
    the working tree, plus untracked sources."""
    try:
        git(root, "rev-parse", "--verify", "--quiet", base + "^{commit}")
    except subprocess.CalledProcessError:
        # A shallow clone cannot diff against the base: said loudly, not failed (whether CI
        # clones shallow is CI's choice, not the code's fault); a full clone without the base
        # is a wrong base and fails.
        if git(root, "rev-parse", "--is-shallow-repository").strip() == "true":
            print("clang-tidy: NOT RUN: this clone is shallow and lacks the tidy base %s; "
                  "fetch the history (git fetch --unshallow) to check the changed sources"
                  % base[:12])
            return None
        fail("the tidy base %s is not in this clone's history: fetch it, or name files, or "
             "run with --all" % base)
    diff = git(root, "diff", "-M", "--unified=0", "--no-color", base, "--")
    changed, current = set(), None
    for line in diff.splitlines():
        if line.startswith("diff --git "):
            current = None
        elif line.startswith("+++ "):
            current = None if line == "+++ /dev/null" else line[len("+++ b/"):]
        elif current and line[:1] in "+-" and not line.startswith(("+++", "---")):
            if line[1:].strip() and not INCLUDE_LINE.match(line):
                changed.add(current)
    untracked = git(root, "ls-files", "--others", "--exclude-standard").splitlines()
    return sorted(f for f in changed.union(untracked) if ours(f))


def finding_file(line):
    """The real path of the file a finding names (None: a line without FILE:LINE:COL)."""
    m = re.match(r"^(.*?):\d+:\d+: ", line)
    return os.path.realpath(m.group(1)) if m else None


def split_findings(found, wanted):
    """(counted, elsewhere): findings in the files being checked, and those clang-tidy
    reported in other project headers the TUs include (not changed: not this change's to fix;
    docs/ci.md lists the known ones). wanted None (--all) counts every finding."""
    if wanted is None:
        return list(found), []
    counted = [f for f in found if finding_file(f) is None or finding_file(f) in wanted]
    return counted, [f for f in found if f not in counted]


def load_database(build):
    path = os.path.join(build, "compile_commands.json")
    if not os.path.exists(path):
        fail("%s is missing: configure with -DCMAKE_EXPORT_COMPILE_COMMANDS=ON" % path)
    with open(path, encoding="utf-8") as f:
        entries = json.load(f)
    return sorted({os.path.realpath(os.path.join(e["directory"], e["file"])) for e in entries})


def header_costs(build, database):
    """For each TU, its set of included files and their count, from the build's ninja
    dependency log (ninja -t deps); empty when the build has none."""
    build, by_object = os.path.realpath(build), {}
    with open(os.path.join(build, "compile_commands.json"), encoding="utf-8") as f:
        for e in json.load(f):
            m = re.search(r"\s-o\s+(\S+)", e["command"]) if "command" in e else None
            if m:
                tu = os.path.realpath(os.path.join(e["directory"], e["file"]))
                by_object[os.path.normpath(os.path.join(e["directory"], m.group(1)))] = tu
    try:
        out = subprocess.run(["ninja", "-C", build, "-t", "deps"], capture_output=True,
                             text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {}
    deps, current = {}, None
    for line in out.splitlines():
        if line and not line[0].isspace():
            obj = os.path.normpath(os.path.join(build, line.split(":")[0]))
            current = by_object.get(obj)
            if current:
                deps[current] = set()
        elif current and line.strip():
            deps[current].add(os.path.realpath(os.path.join(build, line.strip())))
    return deps


def translation_units(root, build, files, database):
    """The TUs that check FILES: a source file itself; a header through its own .cpp, else
    through the including TU with the fewest included files (the cheapest to parse, by the
    build's dependency log; else the first TU naming it in an #include)."""
    units, missing, deps = [], [], None
    in_db = set(database)
    for f in files:
        path = os.path.realpath(f if os.path.isabs(f) else os.path.join(root, f))
        if path in in_db:
            units.append(path)
            continue
        if not path.endswith(".h"):
            missing.append(f)
            continue
        rel = os.path.relpath(path, root)
        stem = path[:-2] + ".cpp"
        if stem in in_db:
            units.append(stem)
            continue
        if deps is None:
            deps = header_costs(build, database)
        includers = sorted((len(d), tu) for tu, d in deps.items() if path in d)
        includer = includers[0][1] if includers else next(
            (tu for tu in database if _includes(tu, rel)), None)
        if includer:
            units.append(includer)
        else:
            print("tidy_check: %s: no TU of the build includes it; not checked" % rel)
    if missing:
        fail("not in the compile database (a source the build does not compile?): " +
             ", ".join(missing))
    return sorted(set(units))


def _includes(tu, rel):
    try:
        with open(tu, encoding="utf-8", errors="replace") as f:
            return ('#include "%s"' % rel) in f.read()
    except OSError:
        return False


def run_one(tu, build, config):
    start = time.monotonic()
    proc = subprocess.run(["clang-tidy", "-p", build, "--quiet", "--config-file=" + config, tu],
                          capture_output=True, text=True)
    findings = [l for l in proc.stdout.splitlines() if re.search(r": (error|warning): ", l)]
    if proc.returncode != 0 and not findings:
        findings = ["%s: clang-tidy exited %d: %s" % (tu, proc.returncode,
                                                       (proc.stderr or proc.stdout).strip())]
    return tu, time.monotonic() - start, findings


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-p", dest="build", required=True, help="build dir with "
                        "compile_commands.json")
    parser.add_argument("--base", help="check what changed since this commit (default: "
                        "tools/tidy_base.txt)")
    parser.add_argument("--all", action="store_true", help="every TU of the compile database")
    parser.add_argument("--max-tus", type=int, default=25, help="most TUs a run checks "
                        "(default 25: about 6 minutes on CI's 2 cores at the measured 30 s "
                        "of CPU per TU, docs/ci.md)")
    parser.add_argument("--root", default=REPO, help="project root (default: this script's)")
    parser.add_argument("--config", help="clang-tidy configuration (default: ROOT/.clang-tidy)")
    parser.add_argument("-j", dest="jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("files", nargs="*")
    args = parser.parse_args()
    root = os.path.realpath(args.root)
    config = args.config or os.path.join(root, ".clang-tidy")
    database = load_database(args.build)
    wanted = None  # the files whose findings count (None: every file, --all)
    if args.all:
        units = database
    else:
        if args.files:
            files = args.files
        else:
            base = args.base
            if base is None:
                with open(os.path.join(root, "tools", "tidy_base.txt"), encoding="utf-8") as f:
                    base = f.read().split()[0]
            files = changed_files(root, base)
            if files is None:
                return 0
            print("clang-tidy: %d project source(s) changed since %s" % (len(files), base[:12]))
        wanted = {os.path.realpath(f if os.path.isabs(f) or os.path.exists(f)
                                   else os.path.join(root, f)) for f in files}
        units = translation_units(root, args.build, files, database)
        if len(units) > args.max_tus:
            fail("%d TUs to check, more than --max-tus %d (the CI time budget): check them "
                 "locally (tools/tidy_check.py -p BUILD --all), then set tools/tidy_base.txt "
                 "to the checked commit" % (len(units), args.max_tus))
    found, started = {}, time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        for tu, seconds, findings in pool.map(lambda t: run_one(t, args.build, config),
                                              units):
            print("clang-tidy: %-60s %6.1f s %s" % (os.path.relpath(tu, root), seconds,
                                                    "FINDINGS" if findings else "clean"))
            for f in findings:
                found.setdefault(f, None)
    counted, elsewhere = split_findings(found, wanted)
    for f in counted:
        print(f, file=sys.stderr)
    verdict = "%d TU(s) in %.0f s" % (len(units), time.monotonic() - started)
    if elsewhere:
        print("clang-tidy: %d finding(s) in unchanged headers these TUs include, not counted "
              "(docs/ci.md lists them):" % len(elsewhere))
        for f in elsewhere:
            print("  " + f)
    if counted:
        print("clang-tidy: %d finding(s) over %s (checks: %s)" % (len(counted), verdict, config), file=sys.stderr)
        return 1
    print("clang-tidy: clean over " + verdict)
    return 0


if __name__ == "__main__":
    sys.exit(main())
