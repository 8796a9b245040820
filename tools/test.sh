#!/usr/bin/env bash
# Sets up the machine, builds everything with warnings as errors, and runs every test
# (ctest prints what it ran). This is the README's test command and what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
./tools/install-deps.sh
BUILD=${BUILD_DIR:-build}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIMUBENCH_WERROR=ON \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache
cmake --build "$BUILD" -j "$(nproc)"
rc=0
ctest --test-dir "$BUILD" --output-on-failure -j "$(nproc)" --timeout 1500 || rc=$?
if ((rc != 0)); then
  python3 tools/failed_tails.py "$BUILD"  # why each failed, again at the end of the output
  exit "$rc"
fi
