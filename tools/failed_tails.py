#!/usr/bin/env python3
"""After a failed ctest: each failed test's failure lines (check failed, FAIL, gtest's Failure
and values) and its last lines, from ctest's log, so a CI summary that keeps only the head and
tail of the output still shows why each failed.

Usage: failed_tails.py BUILD_DIR [LINES]"""
import os
import sys


def main():
    build = sys.argv[1]
    lines = int(sys.argv[2]) if len(sys.argv) > 2 else 12
    log = os.path.join(build, "Testing", "Temporary", "LastTest.log")
    try:
        text = open(log, errors="replace").read()
    except OSError as e:
        print("failed_tails: %s" % e)
        return
    for block in text.split("\n----------------------------------------------------------\n"
                            "Test Failed.")[:-1]:
        name = block.rsplit(" Testing: ", 1)[-1].split("\n", 1)[0]
        out = block.rsplit("Output:\n", 1)[-1].replace("<end of output>", "")
        rows = [l for l in out.strip().splitlines() if l.strip()]
        keys = ("check failed", "FAIL", "Failure", "Expected", "Actual", "Which is")
        why = [l for l in rows if any(k in l for k in keys)][:lines]
        print("==== %s" % name)
        print("\n".join(why + ["..."] + rows[-4:]))


if __name__ == "__main__":
    main()
