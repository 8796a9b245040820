#!/usr/bin/env bash
# The `imubench` binary's link boundary (issue 13): the offline and control commands link the
# files (io/), plans and the calibration engine, never the daemon, the run store or the
# drivers. Fails when
#   - the CMake link closure of imubench (written at configure time by tests/tools) names a
#     forbidden target or library (imubench_daemon, imubench_store, imubench_drivers, SQLite,
#     libsystemd, libmodbus), or lacks the ones it must have (imubench_cli, imubench_io);
#   - ldd shows libsqlite3, libsystemd or libmodbus;
#   - the binary defines code of the daemon or driver namespaces (static libraries leave no
#     trace in ldd), other than the header-only wire contract of the control socket
#     (daemon/control_protocol.h: the reply/event structs and their JSON readers, which the CLI
#     shares with the daemon by design).
# Usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE PROTOCOL_HEADER
set -euo pipefail
bin=${1:?usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE}
closure=${2:?usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE PROTOCOL_HEADER}
protocol=${3:?usage: link_boundary.sh IMUBENCH_BINARY LINK_CLOSURE_FILE PROTOCOL_HEADER}
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
# The wire contract's names: structs, enums and the inline readers/writers of the header.
wire=$( (grep -oE '^(struct|enum class) [A-Za-z_]+' "$protocol" | awk '{print $NF}'
  grep -oE '^namespace [a-z_]+' "$protocol" | awk '{print $2}'
  grep -oE '^(inline |template <[^>]*> )*[A-Za-z_:<>]+ (toJson|fromJson|parseEvent|serializeEvent)\(' \
    "$protocol" | grep -oE '(toJson|fromJson|parseEvent|serializeEvent)') | sort -u | paste -sd'|')
[[ -n $wire ]] || { echo "no wire contract names found in $protocol" >&2; fail=1; }
# A symbol is daemon/driver code when it names a daemon or driver entity outside the contract.
if bad=$(grep -E '^[0-9a-f]+ [A-Za-z] ' <<<"$syms" | grep -E 'imubench::(daemon|drivers)::' |
  sed -E "s/imubench::daemon::($wire)\b//g" | grep -m5 -E 'imubench::(daemon|drivers)::'); then
  echo "imubench contains daemon/driver code: $bad" >&2
  fail=1
fi
# Sanity: nm saw the binary's own code (a stripped or unreadable file would pass vacuously).
grep -q 'imubench::io::readRecording' <<<"$syms" ||
  { echo "nm found no imubench::io code in $bin" >&2; fail=1; }

((fail == 0)) && echo "imubench links no SQLite, systemd, driver or daemon code"
exit "$fail"
