#!/usr/bin/env bash
# Sets up the machine, builds everything with warnings as errors, runs the static checks
# (function size, clang-tidy on the sources changed since tools/tidy_base.txt) and every test
# (ctest prints what it ran). This is the README's test command and what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
./tools/install-deps.sh
BUILD=${BUILD_DIR:-build}
# The disk this run builds on (a full disk once failed a CI link: say how much there was).
df -h . | awk 'NR == 2 {print "tools/test.sh: " $4 " free on " $6 " before the build"}'
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIMUBENCH_WERROR=ON \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_EXPORT_COMPILE_COMMANDS=ON
cmake --build "$BUILD" -j "$(nproc)"
# Static checks after the build (clang-tidy reads its compile_commands.json); a failure fails
# the run after ctest, so one CI run reports both.
static_failed=()
python3 tools/function_size_check.py || static_failed+=("function size (tools/function_size_check.py)")
python3 tools/tidy_check.py -p "$BUILD" || static_failed+=("clang-tidy (tools/tidy_check.py)")
rc=0
ctest --test-dir "$BUILD" --output-on-failure -j "$(nproc)" --timeout 1500 || rc=$?
if ((rc != 0)); then
  python3 tools/failed_tails.py "$BUILD"  # why each failed, again at the end of the output
fi
if ((${#static_failed[@]})); then
  printf 'static check failed: %s (its findings, FILE:LINE first, are printed above)\n' \
    "${static_failed[@]}" >&2
  ((rc != 0)) || rc=1
fi
exit "$rc"
