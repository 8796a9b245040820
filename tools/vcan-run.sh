#!/usr/bin/env bash
# vcan-run.sh CMD [ARGS...]
#
# Runs CMD where a virtual CAN interface `vcan0` (up) exists, and exits with CMD's exit code.
# 1. If the host already has vcan0, or can create it (root + vcan kernel module), CMD runs
#    directly on the host.
# 2. Otherwise CMD runs inside Debian's user-mode-linux kernel (package user-mode-linux), which
#    has the CAN modules: the host root is mounted as hostfs, the init script loads can, can-raw,
#    can-dev and vcan, creates vcan0, brings lo and vcan0 up, runs CMD in the caller's working
#    directory with the caller's environment, writes CMD's exit code to a file on the host and
#    halts. CMD's stdout/stderr reach our stdout (ctest captures it).
# 3. If neither works the script FAILS (exit 97) with the reason: tests that need CAN never skip.
#
# Environment: VCAN_RUN_MODE=host|uml forces a mode; VCAN_RUN_MEM (default 512M) sets UML memory;
# VCAN_RUN_TIMEOUT (default 900 s) bounds the whole UML run.
set -uo pipefail

if [[ $# -lt 1 ]]; then
  echo "usage: vcan-run.sh CMD [ARGS...]" >&2
  exit 2
fi

mode=${VCAN_RUN_MODE:-auto}

# Listing tests (gtest_discover_tests uses this script as the test executor) needs no CAN.
for a in "$@"; do
  if [[ $a == --gtest_list_tests ]]; then exec "$@"; fi
done

host_vcan_ready() {
  if ip link show vcan0 >/dev/null 2>&1; then
    ip link set vcan0 up >/dev/null 2>&1 || true
    return 0
  fi
  ip link add dev vcan0 type vcan >/dev/null 2>&1 || return 1
  ip link set vcan0 up >/dev/null 2>&1 || return 1
  return 0
}

if [[ $mode == host || ($mode == auto && -z ${VCAN_RUN_INSIDE_UML:-}) ]] && host_vcan_ready; then
  exec "$@"
fi
if [[ $mode == host ]]; then
  echo "vcan-run.sh: VCAN_RUN_MODE=host but the host cannot create vcan0" >&2
  exit 97
fi

uml=$(command -v linux || true)
if [[ -z $uml ]]; then
  echo "vcan-run.sh: FAIL: host has no vcan and user-mode-linux ('linux') is not installed" \
    "(apt-get install user-mode-linux)" >&2
  exit 97
fi
kver=$(ls /usr/lib/uml/modules 2>/dev/null | head -n1)
moddir=/usr/lib/uml/modules/$kver/kernel
for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
  if [[ ! -f $moddir/$m ]]; then
    echo "vcan-run.sh: FAIL: UML module $moddir/$m missing" >&2
    exit 97
  fi
done

work=$(mktemp -d "${TMPDIR:-/tmp}/vcan-run.XXXXXX")
# UML keeps its RAM image in a file: on tmpfs when possible.
ramdir=$work
if [[ -d /dev/shm && -w /dev/shm ]]; then ramdir=$(mktemp -d /dev/shm/vcan-run.XXXXXX); fi
trap 'rm -rf "$work" "$ramdir"' EXIT
rcfile=$work/rc
mkdir "$work/tmp"
envfile=$work/env
# The caller's environment, re-exported inside UML (read-only bash variables filtered out).
export -p | grep -v -E '^declare -[a-zA-Z]*r' >"$envfile"
{
  printf 'cd %q\n' "$PWD"
  printf 'exec'
  printf ' %q' "$@"
  printf '\n'
} >"$work/cmd"

cat >"$work/init" <<EOF
#!/bin/bash
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
mount -t proc proc /proc 2>/dev/null
mount -t sysfs sys /sys 2>/dev/null
mount -t tmpfs tmp /dev/shm 2>/dev/null
fail() { echo "vcan-run.sh (inside UML): \$*"; echo 97 >$rcfile; halt -f; }
for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
  insmod $moddir/\$m || fail "insmod \$m failed"
done
ip link set lo up || fail "lo up failed"
ip link add dev vcan0 type vcan || fail "ip link add vcan0 failed"
ip link set vcan0 up || fail "vcan0 up failed"
. $envfile
export VCAN_RUN_INSIDE_UML=1
# A scratch directory of this run: the host's /tmp is shared by concurrent UML runs, whose
# identical boots hand out the same pids, so pid-named files there would collide.
export TMPDIR=$work/tmp
( . $work/cmd ) </dev/null 2>&1
echo \$? >$rcfile
sync
halt -f
EOF
chmod +x "$work/init"

mem=${VCAN_RUN_MEM:-512M}
timeout_s=${VCAN_RUN_TIMEOUT:-900}
TMPDIR=$ramdir timeout --kill-after=10 "$timeout_s" "$uml" mem="$mem" root=/dev/root \
  rootfstype=hostfs rootflags=/ rw quiet init="$work/init" con=null con0=fd:0,fd:1 \
  </dev/null 2>&1 | tr -d '\r'
uml_rc=${PIPESTATUS[0]}

if [[ ! -s $rcfile ]]; then
  echo "vcan-run.sh: FAIL: user-mode-linux exited ($uml_rc) without reporting the command's" \
    "exit code" >&2
  exit 97
fi
exit "$(cat "$rcfile")"
