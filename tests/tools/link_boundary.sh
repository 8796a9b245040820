#!/usr/bin/env bash
# The `imubench` binary's link boundary (issue 13): the offline and control commands link the
# files (io/), plans and the calibration engine, never the daemon, the run store or the
# drivers. Fails when
#   - the CMake link closure of imubench (written at configure time by tests/tools) names a
#     forbidden target or library (imubench_daemon, imubench_store, imubench_drivers, SQLite,
#     libsystemd, libmodbus), or lacks the ones it must have (imubench_cli, imubench_io);
#   - ldd shows libsqlite3, libsystemd or libmodbus;
#   - the binary defines code of the daemon or driver namespaces (static libraries leave no
#     trace in ldd).
# Usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE
set -euo pipefail
bin=${1:?usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE}
closure=${2:?usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE}
fail=0

for need in imubench_cli imubench_io; do
  grep -qx "$need" "$closure" || { echo "link closure lacks $need ($closure)" >&2; fail=1; }
done
forbidden='^(imubench_daemon|imubench_store|imubench_drivers|SQLite::SQLite3|PkgConfig::SYSTEMD|PkgConfig::MODBUS)$'
if bad=$(grep -E "$forbidden" "$closure"); then
  echo "imubench links (CMake): $bad" | tr '\n' ' ' >&2; echo >&2
  fail=1
fi

libs=$(ldd "$bin")
if bad=$(grep -E 'libsqlite3|libsystemd|libmodbus' <<<"$libs"); then
  echo "imubench loads: $bad" >&2
  fail=1
fi

# Code defined (not merely referenced) in the daemon and driver namespaces.
syms=$(nm -C --defined-only "$bin")
if bad=$(grep -m5 -E '^[0-9a-f]+ [A-Za-z] imubench::(daemon|drivers)::' <<<"$syms"); then
  echo "imubench contains daemon/driver code: $bad" >&2
  fail=1
fi
# Sanity: nm saw the binary's own code (a stripped or unreadable file would pass vacuously).
grep -q 'imubench::io::readRecording' <<<"$syms" ||
  { echo "nm found no imubench::io code in $bin" >&2; fail=1; }

((fail == 0)) && echo "imubench links no SQLite, systemd, driver or daemon code"
exit "$fail"
