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
ctest --test-dir "$BUILD" --output-on-failure -j "$(nproc)" --timeout 1500
