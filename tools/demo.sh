#!/usr/bin/env bash
# The README's first command: set up the machine, build, and run the main job on the
# embedded defaults (simulate the bundled 12-run two-axis plan and print each run).
# Extra arguments go to `imubench run` (e.g. --out /tmp/rec, --noise none, --seed 7).
set -euo pipefail
cd "$(dirname "$0")/.."
./tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build --target imubench -j "$(nproc)"
exec build/tools/imubench run "$@"
